// The page a race's viewer URL shows while the race has no 3D view yet: poll the race once a second, load the
// view once the API says it is open (viewer_url set), and say so when the race ends without one. A reload is
// made at most once in RELOAD_GAP_MS (remembered in sessionStorage), so this page can never reload in a loop.
"use strict";

(function () {
  const card = document.getElementById("viewer-wait");
  if (!card) return;
  const raceId = card.dataset.raceId;
  const why = document.getElementById("why");
  const over = new Set(["finished", "stopped", "aborted"]);
  const RELOAD_GAP_MS = 10000;
  const POLL_MS = 1000;
  const MAX_POLLS = 300;
  const reloadKey = `karting-viewer-reload:${raceId}`;
  let polls = 0;

  function mayReload() {
    const last = Number(sessionStorage.getItem(reloadKey) || 0);
    return Date.now() - last > RELOAD_GAP_MS;
  }

  async function poll() {
    polls += 1;
    try {
      const response = await fetch(`/api/races/${encodeURIComponent(raceId)}`, {headers: {Accept: "application/json"}});
      if (response.status === 404) { why.textContent = "There is no such race."; return; }
      if (response.ok) {
        const race = await response.json();
        // the view is open, or the race ended without one (then the server answers the "race over" page)
        const ready = race.viewer_url || over.has(race.status);
        if (ready && mayReload()) {
          sessionStorage.setItem(reloadKey, String(Date.now()));
          location.reload();
          return;
        }
        why.textContent = `The race is ${race.status}; its 3D view opens shortly…`;
      }
    } catch (_) { /* server restarting: keep trying */ }
    if (polls < MAX_POLLS) setTimeout(poll, POLL_MS);
  }

  setTimeout(poll, POLL_MS);
})();
