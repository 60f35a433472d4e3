// Loaded first on viser's client page of a race's live 3D view. viser's client reconnects its websocket (in a
// Worker) forever; once the race's scene has closed (the API's viewer_url is gone) this stops it and loads the
// page the viewer URL now answers: "race over", with links to the result and the replay. One request every
// POLL_MS while the view is open.
"use strict";

(function () {
  const match = location.pathname.match(/^\/races\/([^/]+)\/viewer\/$/);
  if (!match) return;
  const raceId = decodeURIComponent(match[1]);
  const POLL_MS = 2000;
  const workers = [];
  const NativeWorker = window.Worker;
  window.Worker = class extends NativeWorker {
    constructor(...args) {
      super(...args);
      workers.push(this);
    }
  };

  async function poll() {
    try {
      const response = await fetch(`/api/races/${encodeURIComponent(raceId)}`, {headers: {Accept: "application/json"}});
      const gone = response.status === 404 || (response.ok && !(await response.json()).viewer_url);
      if (gone) {
        for (const worker of workers) worker.terminate();
        location.replace(location.href);
        return;
      }
    } catch (_) { /* server restarting: keep trying */ }
    setTimeout(poll, POLL_MS);
  }

  setTimeout(poll, POLL_MS);
})();
