# Runs check_library_graph.py on docs/architecture.md with the maps -> session
# arrow removed from the table; the checker must name that arrow (the test's
# PASS_REGULAR_EXPRESSION) and exit non-zero.
file(READ ${SOURCE_DIR}/docs/architecture.md text)
string(REPLACE "| `estimation` `files` `session` `spectral` |" "| `estimation` `files` `spectral` |" mutated "${text}")
if(mutated STREQUAL text)
  message(FATAL_ERROR "the maps row of docs/architecture.md changed: update check_mutated.cmake")
endif()
file(WRITE ${OUT} "${mutated}")
execute_process(COMMAND ${PYTHON} ${SOURCE_DIR}/tests/architecture/check_library_graph.py ${SOURCE_DIR} ${OUT}
                RESULT_VARIABLE status)
if(status EQUAL 0)
  message(FATAL_ERROR "check_library_graph.py accepted a table without the maps -> session arrow")
endif()
