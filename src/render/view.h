// `mosyn view`: one self-contained HTML page that plays motions in the browser with three.js.
// The page inlines the viewer script (web/src/viewer.js with three.js, bundled by esbuild at build
// time and embedded in the library) and the motions as JSON, so it works offline from disk
// (file:// pages cannot import modules).
#pragma once

#include <string>
#include <vector>

#include "render/scene.h"

namespace mosyn::render {

// The bundled viewer script; "" when mosyn was built without npm/node.
const char* viewer_script();

// True when viewer_script() is not empty.
bool viewer_available();

// The motions as the page's JSON: {"title", "motions": [{"name", "fps", "color" "#rrggbb", "names"
// [J], "parents" [J], "frames" [T][J * 3]}]} with positions in metres (+Y up) rounded to 0.1 mm.
std::string viewer_data_json(const std::vector<RenderMotion>& motions, const std::string& title);

// The whole HTML page: canvas with solid bodies, soft floor shadows, feet darkened while planted
// and ground paths; controls (play/pause, time scrubber, speed, overlay toggle, camera menu: frame
// all figures or follow one; orbit by mouse, zoom by wheel), legend with one colour per motion (a
// click follows it). Motions are laid out side by side in a near-square grid of cells; a page of
// more than three motions starts following the first ("PAGE.html#follow=-1" frames all).
// "</" inside the inlined script and data is escaped so neither can end its <script> element.
// Throws mosyn::Error when the viewer script is unavailable (mosyn built without npm) or there is
// no motion.
std::string viewer_page(const std::vector<RenderMotion>& motions, const std::string& title = "mosyn");

// The live page of `mosyn serve` (src/serve/README.md): the same viewer in live mode. It opens a
// WebSocket to the server it came from and draws the characters the server streams; arrow keys,
// WASD or a gamepad steer the selected one; a style menu (when the model has styles), a speed
// control, add/remove character buttons, the trail of each path walked, a follow camera. Test hooks:
// window.mosynLive (frames received, root positions with arrival times, key-to-response latencies).
// Throws mosyn::Error when the viewer script is unavailable (mosyn built without npm).
std::string live_page(const std::string& title = "mosyn live");

// viewer_page written atomically.
void write_viewer_page(const std::string& path, const std::vector<RenderMotion>& motions,
                       const std::string& title = "mosyn");

}  // namespace mosyn::render
