// Loaded first on viser's client page of a race's live 3D view. viser's client reconnects its websocket (in a
// Worker) forever; once the race's scene has closed (the API's viewer_url is gone) this stops it and loads the
// page the viewer URL now answers: "race over", with links to the result and the replay. When the API names
// another page as the race's view (its replay), it goes there. One request every POLL_MS while the view is open.
"use strict";

(function () {
  const match = location.pathname.match(/^\/races\/([^/]+)\/viewer\/$/);
  if (!match) return;
  const raceId = decodeURIComponent(match[1]);
  const POLL_MS = 2000;
  const MOVE_AFTER_MS = 3000;
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
      const race = response.ok ? await response.json() : null;
      if (response.status === 404 || (race && !race.viewer_url)) {
        for (const worker of workers) worker.terminate();
        location.replace(location.href);
        return;
      }
      // the race's view moved (e.g. to its replay once over): follow it after a moment to see the finish
      if (race && race.viewer_url !== location.pathname) {
        setTimeout(() => { for (const worker of workers) worker.terminate(); location.replace(race.viewer_url); }, MOVE_AFTER_MS);
        return;
      }
    } catch (_) { /* server restarting: keep trying */ }
    setTimeout(poll, POLL_MS);
  }

  setTimeout(poll, POLL_MS);
})();
