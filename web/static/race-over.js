// The "race over" page: name the winner from the race's result (one request; nothing polls here).
"use strict";

(async function () {
  const card = document.getElementById("race-over");
  if (!card) return;
  const raceId = card.dataset.raceId;
  const line = document.getElementById("winner");
  try {
    const result = await fetchJSON(`/api/races/${encodeURIComponent(raceId)}/result`);
    const winner = (result.karts || []).find((k) => k.index === result.winner);
    line.textContent = winner ? `Winner: ${kartLabel(winner.name, winner.controller)}` : "Nobody finished.";
  } catch (error) {
    line.textContent = error.status === 409 ? "This race has no result." : "";
  }
})();
