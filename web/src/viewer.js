// mosyn viewer: plays motions written by `mosyn view` (and shown by `mosyn report`) in the
// browser with three.js. The page embeds the motions as JSON in
// <script id="mosyn-data" type="application/json">:
//   {"motions": [{"name", "fps", "color": "#rrggbb", "names": [J], "parents": [J],
//                 "frames": [[x0, y0, z0, x1, ...] per frame]}]}   (metres, +Y up)
// and this file bundled inline (esbuild IIFE), so the page works offline from disk.
// The live page of `mosyn serve` has {"live": true} there instead (live.js: characters streamed
// over a WebSocket and steered by the keyboard or a gamepad).
// Solid bodies with soft shadows, feet coloured while planted, ground paths; the camera frames
// what moves (all figures) or follows one (the camera menu, a click on a legend entry, or
// "#follow=K" in the address, -1 for all; pages of more than three motions start following the
// first).
import { startLive } from './live.js';
import { startPlayback } from './playback.js';

const data = JSON.parse(document.getElementById('mosyn-data').textContent);
if (data.live) startLive(data);
else startPlayback(data);
