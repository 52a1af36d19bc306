# ctest occt_results_store: cadinterp-occt-results --store, run three times on the load-angle
# wrench with one store (cmake -DTOOL=cadinterp-occt-results -DWORK=dir -P this file).
#   1. a new store: every point from the host;
#   2. the same options: every point from the store, no host call, the asset identical byte for
#      byte;
#   3. other host options (force=100): the store refuses them, the run fails and says why.
file(REMOVE_RECURSE ${WORK})
set(common --models wrench_load --points 1 --max-samples 3 --max-depth 1 --store ${WORK}/store)
set(asset occt_results_wrench_load.cadi)

function(run dir extra)
  execute_process(COMMAND ${TOOL} ${common} --dir ${WORK}/${dir} ${extra}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  set(rc ${rc} PARENT_SCOPE)
  set(log "${out}${err}" PARENT_SCOPE)
endfunction()

run(first "")
if(NOT rc EQUAL 0 OR NOT log MATCHES "store [^\n]*: 0 points read, ([1-9][0-9]*) host evaluations")
  message(FATAL_ERROR "first run (exit ${rc}) did not fill a new store:\n${log}")
endif()
set(points ${CMAKE_MATCH_1})

run(second "")
if(NOT rc EQUAL 0 OR NOT log MATCHES "store [^\n]*: ${points} points read, 0 host evaluations")
  message(FATAL_ERROR "second run (exit ${rc}) did not read all ${points} points:\n${log}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/first/${asset}
                        ${WORK}/second/${asset} RESULT_VARIABLE differ)
if(differ)
  message(FATAL_ERROR "the asset built from the store differs from the first")
endif()

run(third "--host-options;force=100")
if(NOT rc EQUAL 1 OR NOT log MATCHES "holds samples of another model")
  message(FATAL_ERROR "other host options (exit ${rc}) were not refused:\n${log}")
endif()
file(REMOVE_RECURSE ${WORK})
