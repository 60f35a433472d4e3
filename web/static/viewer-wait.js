// On the "no live viewer" page: while the race is still starting, wait for its 3D view and then load it.
"use strict";

(function () {
  const match = location.pathname.match(/^\/races\/([^/]+)\/viewer\/?$/);
  if (!match) return;
  const raceId = match[1];
  const over = new Set(["finished", "stopped", "aborted"]);
  const why = document.getElementById("why");
  let tries = 0;

  async function poll() {
    tries += 1;
    try {
      const response = await fetch(`/api/races/${raceId}`, {headers: {Accept: "application/json"}});
      if (response.status === 404) { why.textContent = "There is no such race."; return; }
      if (response.ok) {
        const race = await response.json();
        if (race.viewer_url) { location.reload(); return; }
        if (over.has(race.status)) { why.textContent = `The race is over (${race.status}) and its 3D view is closed.`; return; }
        why.textContent = `The race is ${race.status}; its 3D view opens shortly…`;
      }
    } catch (_) { /* server restarting: keep trying */ }
    if (tries < 300) setTimeout(poll, 1000);
  }

  poll();
})();
