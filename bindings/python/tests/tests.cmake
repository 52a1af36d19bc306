# The pytest suites, one ctest each (label `python`), run by Debian's python3 against the package
# in the build tree. Not part of the asan/tsan presets: the top level skips bindings/python there.
execute_process(COMMAND "${CADINTERP_PYTHON}" -c "import pytest" RESULT_VARIABLE _pytest_rc
                OUTPUT_QUIET ERROR_QUIET)
if(NOT _pytest_rc EQUAL 0)
  message(WARNING "Python bindings: ${CADINTERP_PYTHON} has no pytest: its tests are not added "
                  "(scripts/install-deps.sh installs python3-pytest)")
  return()
endif()

set(_env
  "PYTHONPATH=${CMAKE_CURRENT_BINARY_DIR}"
  # No __pycache__ or .pytest_cache in the source tree.
  "PYTHONDONTWRITEBYTECODE=1"
  "CADINTERP_CASES=${PROJECT_SOURCE_DIR}/conformance/cases"
  "CADINTERP_CONFORMANCE_RUNNER=$<TARGET_FILE:cadinterp-conformance>"
  "MPLBACKEND=Agg")
foreach(_suite conformance runtime errors builder example optimize)
  add_test(NAME python_${_suite}
           COMMAND "${CADINTERP_PYTHON}" -m pytest -q -p no:cacheprovider
                   ${CMAKE_CURRENT_SOURCE_DIR}/tests/test_${_suite}.py
           WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  set_tests_properties(python_${_suite} PROPERTIES LABELS python ENVIRONMENT "${_env}")
endforeach()

add_test(NAME python_staged_install
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/tests/staged_install.sh ${PROJECT_BINARY_DIR}
                 ${CMAKE_INSTALL_PREFIX} ${CADINTERP_PYTHON_INSTALL_DIR} ${CMAKE_INSTALL_LIBDIR}
                 ${CADINTERP_PYTHON} ${PROJECT_SOURCE_DIR}/conformance/cases/valid/k2_linear/asset.cadi)
# RESOURCE_LOCK: every `cmake --install` of the build tree writes its install_manifest.txt.
set_tests_properties(python_staged_install PROPERTIES LABELS python SKIP_RETURN_CODE 77
                     RESOURCE_LOCK cmake_install_manifest)
