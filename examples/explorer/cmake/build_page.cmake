# Build-time step of cadinterp_explorer_page:
#   cmake -DSRC=examples/explorer -DOUT=<web root> -DNODE=<node> -DSTAMP=<file> -P build_page.cmake
# Runs vite from SRC/node_modules (offline). Without node_modules it warns and writes no stamp,
# so the next build tries again (after `npm ci`).
set(_vite ${SRC}/node_modules/vite/bin/vite.js)
if(NOT EXISTS ${_vite} OR NOT EXISTS ${SRC}/node_modules/three/package.json)
  message(WARNING
    "explorer: ${SRC}/node_modules is missing or incomplete: run `npm ci` there (it needs the "
    "npm registry once), then build again. Until then `cadinterp explore` reports the page as "
    "not built.")
  file(REMOVE ${STAMP})
  return()
endif()
execute_process(
  COMMAND ${CMAKE_COMMAND} -E env EXPLORER_OUT_DIR=${OUT} ${NODE} ${_vite} build
  WORKING_DIRECTORY ${SRC}
  RESULT_VARIABLE _rc)
if(NOT _rc EQUAL 0)
  message(FATAL_ERROR "explorer: vite build failed (${_rc})")
endif()
if(NOT EXISTS ${OUT}/index.html)
  message(FATAL_ERROR "explorer: vite build wrote no ${OUT}/index.html")
endif()
file(TOUCH ${STAMP})
