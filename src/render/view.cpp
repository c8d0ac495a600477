#include "render/view.h"

#include "io/html.h"

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/atomic_file.h"

namespace mosyn::render {
namespace {

// "</" would end the enclosing <script>; "<\/" means the same in JS strings, regexes and JSON.
std::string escape_script_end(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '<' && i + 1 < text.size() && text[i + 1] == '/') {
      out += "<\\/";
      ++i;
    } else {
      out += text[i];
    }
  }
  return out;
}

constexpr const char* kStyle = R"css(
html, body { margin: 0; height: 100%; overflow: hidden; font: 14px sans-serif; background: #f4f4f4; }
#view { position: absolute; left: 0; top: 0; width: 100%; height: calc(100% - 44px); display: block; }
#bar { position: absolute; left: 0; bottom: 0; width: 100%; height: 44px; box-sizing: border-box;
       display: flex; align-items: center; gap: 10px; padding: 0 10px; background: #fff; border-top: 1px solid #ddd; }
#scrub { flex: 1; }
#legend { position: absolute; left: 10px; top: 8px; }
#legend .item { margin-right: 14px; cursor: pointer; }
#legend .swatch { display: inline-block; width: 12px; height: 12px; margin-right: 5px; vertical-align: -1px; }
#clock { font-variant-numeric: tabular-nums; min-width: 110px; }
#help { position: absolute; right: 10px; top: 8px; color: #555; }
#status { flex: 1; text-align: right; color: #555; font-variant-numeric: tabular-nums; }
)css";

}  // namespace

bool viewer_available() { return std::strlen(viewer_script()) > 0; }

std::string viewer_data_json(const std::vector<RenderMotion>& motions, const std::string& title) {
  nlohmann::json j;
  j["title"] = title;
  nlohmann::json list = nlohmann::json::array();
  for (const auto& m : motions) {
    if (m.positions_m.size() != static_cast<size_t>(m.num_frames) * m.num_joints)
      throw Error("motion '" + m.name + "' is inconsistent");
    nlohmann::json jm;
    jm["name"] = m.name;
    jm["fps"] = m.fps;
    jm["color"] = format_color(m.color);
    jm["names"] = m.joint_names;
    jm["parents"] = m.parents;
    nlohmann::json frames = nlohmann::json::array();
    for (int t = 0; t < m.num_frames; ++t) {
      std::vector<double> f;
      f.reserve(static_cast<size_t>(m.num_joints) * 3);
      for (int k = 0; k < m.num_joints; ++k)
        for (int c = 0; c < 3; ++c) f.push_back(std::round(m.position(t, k)[c] * 1e4) / 1e4);
      frames.push_back(std::move(f));
    }
    jm["frames"] = std::move(frames);
    list.push_back(std::move(jm));
  }
  j["motions"] = std::move(list);
  return j.dump();
}

namespace {

void require_viewer() {
  if (!viewer_available())
    throw Error("the browser viewer is not available: mosyn was built without npm/node, which bundle three.js "
                "at build time (install npm and rebuild)");
}

// The page up to the canvas and legend, shared by the playback and live pages.
std::string page_head(const std::string& title) {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" + io::escape_html(title) +
         "</title>\n<style>" + kStyle + "</style>\n</head>\n<body>\n<canvas id=\"view\"></canvas>\n<div id=\"legend\"></div>\n";
}

// The data element and the viewer script that reads it; the end of every page.
std::string page_tail(const std::string& data_json) {
  return "<script id=\"mosyn-data\" type=\"application/json\">" + escape_script_end(data_json) + "</script>\n<script>" +
         escape_script_end(viewer_script()) + "</script>\n</body>\n</html>\n";
}

}  // namespace

std::string viewer_page(const std::vector<RenderMotion>& motions, const std::string& title) {
  require_viewer();
  if (motions.empty()) throw Error("nothing to view");
  for (const auto& m : motions)
    if (m.num_frames < 1) throw Error("motion '" + m.name + "' has no frames");
  std::string page = page_head(title);
  page +=
      "<div id=\"bar\"><button id=\"play\">Pause</button><input id=\"scrub\" type=\"range\" min=\"0\" value=\"0\">"
      "<span id=\"clock\"></span><label>speed <select id=\"speed\"><option value=\"0.25\">0.25x</option>"
      "<option value=\"0.5\">0.5x</option><option value=\"1\" selected>1x</option><option value=\"2\">2x</option>"
      "</select></label><label><input id=\"overlay\" type=\"checkbox\"> overlay</label>"
      "<select id=\"camera\" title=\"camera\"><option value=\"-1\">frame all</option></select></div>\n";
  return page + page_tail(viewer_data_json(motions, title));
}

std::string live_page(const std::string& title) {
  require_viewer();
  std::string page = page_head(title);
  page +=
      "<div id=\"help\">arrow keys / WASD or a gamepad steer the selected character</div>\n"
      "<div id=\"bar\"><select id=\"character\" title=\"steered and followed character\"></select>"
      "<label id=\"style-label\">style <select id=\"style\"></select></label>"
      "<label>speed <input id=\"speed\" type=\"range\" min=\"0.3\" max=\"3\" step=\"0.1\" value=\"1.3\">"
      "<span id=\"speed-value\">1.3 m/s</span></label><button id=\"add\">add character</button>"
      "<button id=\"remove\">remove</button><label><input id=\"follow\" type=\"checkbox\" checked> follow</label>"
      "<span id=\"status\">connecting...</span></div>\n";
  return page + page_tail(nlohmann::json{{"live", true}, {"title", title}}.dump());
}

void write_viewer_page(const std::string& path, const std::vector<RenderMotion>& motions, const std::string& title) {
  io::write_file_atomically(path, viewer_page(motions, title));
}

}  // namespace mosyn::render
