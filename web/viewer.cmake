# The browser viewer of `mosyn view`: web/src/viewer.js and three.js (from npm) bundled by esbuild
# into one script at build time, embedded into mosyn_render as a generated C++ source. Without
# npm/node the build still succeeds with an empty script, and `mosyn view` then says what is missing.
set(_viewer_cpp ${CMAKE_BINARY_DIR}/generated/viewer_script.cpp)
set(_web_src ${CMAKE_CURRENT_LIST_DIR})
find_program(MOSYN_NPM npm)
find_program(MOSYN_NODE node)
if(MOSYN_NPM AND MOSYN_NODE)
  set(_web_build ${CMAKE_BINARY_DIR}/web)
  file(MAKE_DIRECTORY ${_web_build}/src ${CMAKE_BINARY_DIR}/generated)
  add_custom_command(
    OUTPUT ${_viewer_cpp}
    COMMAND ${CMAKE_COMMAND} -E copy_if_different ${_web_src}/package.json ${_web_src}/package-lock.json ${_web_build}
    COMMAND ${CMAKE_COMMAND} -E copy_if_different ${_web_src}/src/viewer.js ${_web_build}/src
    COMMAND ${MOSYN_NPM} ci --no-audit --no-fund --loglevel=error
    COMMAND ${_web_build}/node_modules/.bin/esbuild src/viewer.js --bundle --minify --format=iife
            --log-level=warning --outfile=viewer.bundle.js
    COMMAND ${MOSYN_NODE} ${_web_src}/embed.cjs viewer.bundle.js ${_viewer_cpp}
    WORKING_DIRECTORY ${_web_build}
    DEPENDS ${_web_src}/src/viewer.js ${_web_src}/package.json ${_web_src}/package-lock.json ${_web_src}/embed.cjs
    COMMENT "Bundling the three.js viewer (npm ci, esbuild)"
    VERBATIM)
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
