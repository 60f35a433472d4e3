// Pages that may be shown inside another page (the drive page's viewer frame) drop their own header there.
"use strict";
if (window.top !== window.self) document.documentElement.classList.add("framed");
