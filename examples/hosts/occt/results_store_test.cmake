# ctest occt_results_store: cadinterp-occt-results --store, run three times on the load-angle
# wrench with one store (cmake -DTOOL=cadinterp-occt-results -DWORK=dir -P this file).
#   1. a new store: every point from the host;
#   2. the same options: every point from the store, no host call, the asset identical byte for
#      byte;
#   3. other host options (force=100): the store refuses them, the run fails and says why.
file(REMOVE_RECURSE ${WORK})
set(common --models wrench_load --points 1 --max-samples 3 --max-depth 1 --store ${WORK}/store)
set(asset occt_results_wrench_load.cadi)

# Runs the tool into WORK/dir with `extra` options; fails the test with `why` unless it exits
# with `want_rc` and its output matches `pattern` (CMAKE_MATCH_1 is passed back).
function(expect dir extra want_rc pattern why)
  execute_process(COMMAND ${TOOL} ${common} --dir ${WORK}/${dir} ${extra}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL want_rc OR NOT "${out}${err}" MATCHES "${pattern}")
    message(FATAL_ERROR "${dir} run (exit ${rc}) ${why}:\n${out}${err}")
  endif()
  set(CMAKE_MATCH_1 "${CMAKE_MATCH_1}" PARENT_SCOPE)
endfunction()

expect(first "" 0 "store [^\n]*: 0 points read, ([1-9][0-9]*) host evaluations"
       "did not fill a new store")
set(points ${CMAKE_MATCH_1})
expect(second "" 0 "store [^\n]*: ${points} points read, 0 host evaluations"
       "did not read all ${points} points")
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/first/${asset}
                        ${WORK}/second/${asset} RESULT_VARIABLE differ)
if(differ)
  message(FATAL_ERROR "the asset built from the store differs from the first")
endif()
expect(third "--host-options;force=100" 1 "holds samples of another model"
       "did not refuse other host options")
file(REMOVE_RECURSE ${WORK})
