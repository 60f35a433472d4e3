// Loaded into a stored race's replay player (viser's page): names the tab after the race.
"use strict";

(function () {
  const match = location.pathname.match(/^\/races\/([^/]+)\/replay\/?$/);
  if (match) document.title = `Replay · race ${decodeURIComponent(match[1])} · HeadToHead Karting`;
})();
