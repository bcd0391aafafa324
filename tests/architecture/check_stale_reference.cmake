# A two-file tree where a comment names session/moved_away.hpp, which does not
# exist, and one that names session/here.hpp, which does: the checker must
# report the first with its place, not the second, and
# exit non-zero.
file(REMOVE_RECURSE ${OUT})
file(WRITE ${OUT}/session/include/chromo/session/here.hpp "#pragma once\n")
file(WRITE ${OUT}/session/src/user.cpp "// see session/here.hpp and session/moved_away.hpp\n")
execute_process(COMMAND ${PYTHON} ${SOURCE_DIR}/tests/architecture/check_file_references.py ${OUT}
                RESULT_VARIABLE status OUTPUT_VARIABLE output)
message("${output}")
if(status EQUAL 0 OR output MATCHES "here.hpp" OR NOT output MATCHES "session/src/user.cpp:1: session/moved_away.hpp")
  message(FATAL_ERROR "check_file_references.py: wrong verdict on the fixture tree")
endif()
