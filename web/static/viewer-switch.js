// Loaded into a live race's 3D view: once the race is over, move to the address the API then gives as the
// race's viewer (its replay), a few seconds after the end so the finish can be seen.
"use strict";

(function () {
  const match = location.pathname.match(/^\/races\/([^/]+)\/viewer\/?$/);
  if (!match) return;
  const raceId = match[1];
  const over = new Set(["finished", "stopped", "aborted"]);
  const POLL_MS = 2000;
  const LINGER_MS = 3000;

  async function poll() {
    try {
      const response = await fetch(`/api/races/${raceId}`, {headers: {Accept: "application/json"}});
      if (response.status === 404) return;  // no such race: nothing will change
      if (response.ok) {
        const race = await response.json();
        if (over.has(race.status)) {
          if (race.viewer_url && race.viewer_url !== location.pathname) {
            setTimeout(() => location.replace(race.viewer_url), LINGER_MS);
          }
          return;  // over: no more polling either way
        }
      }
    } catch (_) { /* server restarting: keep trying */ }
    setTimeout(poll, POLL_MS);
  }

  setTimeout(poll, POLL_MS);
})();
