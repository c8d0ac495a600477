# The browser viewer of `mosyn view`: web/src/viewer.js and three.js (from npm) bundled by esbuild
# into one script at build time, embedded into mosyn_render as a generated C++ source. Without
# npm/node the build still succeeds with an empty script, and `mosyn view` then says what is missing.
set(_viewer_cpp ${CMAKE_BINARY_DIR}/generated/viewer_script.cpp)
set(_web_src ${CMAKE_CURRENT_LIST_DIR})
file(GLOB _web_modules CONFIGURE_DEPENDS ${_web_src}/src/*.js)
find_program(MOSYN_NPM npm)
find_program(MOSYN_NODE node)
if(MOSYN_NPM AND MOSYN_NODE)
  set(_web_build ${CMAKE_BINARY_DIR}/web)
  file(MAKE_DIRECTORY ${_web_build}/src ${CMAKE_BINARY_DIR}/generated)
  add_custom_command(
    OUTPUT ${_viewer_cpp}
    COMMAND ${CMAKE_COMMAND} -E copy_if_different ${_web_src}/package.json ${_web_src}/package-lock.json ${_web_build}
    COMMAND ${CMAKE_COMMAND} -E copy_if_different ${_web_modules} ${_web_build}/src
    COMMAND ${MOSYN_NPM} ci --no-audit --no-fund --loglevel=error
    COMMAND ${_web_build}/node_modules/.bin/esbuild src/viewer.js --bundle --minify --format=iife
            --log-level=warning --outfile=viewer.bundle.js
    COMMAND ${MOSYN_NODE} ${_web_src}/embed.cjs viewer.bundle.js ${_viewer_cpp}
    WORKING_DIRECTORY ${_web_build}
    DEPENDS ${_web_modules} ${_web_src}/package.json ${_web_src}/package-lock.json ${_web_src}/embed.cjs
    COMMENT "Bundling the three.js viewer (npm ci, esbuild)"
    VERBATIM)
  # The glTF probe of the browser tests (web/src/gltf_probe.js: three.js's GLTFLoader plays an
  # exported file and reports joint positions); a build-tree file, not part of the binary.
  # With it, the Khronos glTF validator (npm gltf-validator) and its runner web/validate_gltf.mjs.
  set(MOSYN_GLTF_PROBE_JS ${_web_build}/gltf_probe.bundle.js CACHE INTERNAL "")
  set(MOSYN_GLTF_VALIDATOR ${_web_build}/validate_gltf.mjs CACHE INTERNAL "")
  add_custom_command(
    OUTPUT ${MOSYN_GLTF_PROBE_JS} ${MOSYN_GLTF_VALIDATOR}
    COMMAND ${CMAKE_COMMAND} -E copy_if_different ${_web_src}/validate_gltf.mjs ${_web_build}
    COMMAND ${_web_build}/node_modules/.bin/esbuild src/gltf_probe.js --bundle --minify --format=iife
            --log-level=warning --outfile=gltf_probe.bundle.js
    WORKING_DIRECTORY ${_web_build}
    DEPENDS ${_viewer_cpp} ${_web_src}/src/gltf_probe.js ${_web_src}/validate_gltf.mjs
    COMMENT "Bundling the glTF browser probe (esbuild)"
    VERBATIM)
  add_custom_target(mosyn_gltf_probe DEPENDS ${MOSYN_GLTF_PROBE_JS} ${MOSYN_GLTF_VALIDATOR})
else()
  message(STATUS "npm/node not found: `mosyn view` will be unavailable")
  file(GENERATE OUTPUT ${_viewer_cpp} CONTENT
"// Generated without npm: no viewer script.
#include \"render/view.h\"
namespace mosyn::render {
const char* viewer_script() { return \"\"; }
}  // namespace mosyn::render
")
endif()
target_sources(mosyn_render PRIVATE ${_viewer_cpp})
