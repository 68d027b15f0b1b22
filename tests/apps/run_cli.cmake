# run_cli.cmake: runs the shearzone binary the way a user does and checks the outcome.
#
#   cmake -DEXE=... -DARGS="a;b;c" -DWORKDIR=... -DEXPECT_CODE=N
#         [-DEXPECT_STDERR=regex] [-DEXPECT_STDOUT=regex]
#         [-DEXPECT_ABSENT=path;...] [-DEXPECT_PRESENT=path;...]
#         [-DSETUP_FILE=path -DSETUP_TEXT=text] [-DSETUP_ARGS=a|b|c] [-DSETUP_ARGS2=a|b|c]
#         [-DEXPECT_FILE=path -DEXPECT_FILE_REGEX=regex] [-DEXPECT_SAME_STDOUT=regex] -P run_cli.cmake
#
# SETUP_ARGS runs the same executable once before the test (e.g. to render inputs);
# SETUP_ARGS2, when given, a second time after it (e.g. to measure what it rendered).
# EXPECT_FILE_REGEX must match the text of EXPECT_FILE (relative to WORKDIR) after the run.
# EXPECT_SAME_STDOUT: the first match of the regex in the test's stdout must exist and be
# the same as in the SETUP_ARGS run's stdout (e.g. two runs print the same state hash).
#
# WORKDIR is wiped first. Paths in EXPECT_ABSENT/PRESENT are relative to WORKDIR.
# Failure tests check exit code, a one-line stderr message, and that no output exists.
string(REPLACE "|" ";" ARGS "${ARGS}")
string(REPLACE "|" ";" EXPECT_ABSENT "${EXPECT_ABSENT}")
string(REPLACE "|" ";" EXPECT_PRESENT "${EXPECT_PRESENT}")
file(REMOVE_RECURSE "${WORKDIR}")
file(MAKE_DIRECTORY "${WORKDIR}")
if(DEFINED SETUP_FILE)
  string(REPLACE "\\n" "\n" text "${SETUP_TEXT}")
  file(WRITE "${WORKDIR}/${SETUP_FILE}" "${text}")
endif()

if(DEFINED SETUP_ARGS)
  string(REPLACE "|" ";" SETUP_ARGS "${SETUP_ARGS}")
  execute_process(COMMAND "${EXE}" ${SETUP_ARGS} WORKING_DIRECTORY "${WORKDIR}"
                  RESULT_VARIABLE setup_code OUTPUT_VARIABLE setup_out ERROR_VARIABLE setup_err)
  if(NOT setup_code EQUAL 0)
    message(FATAL_ERROR "setup command failed (${setup_code}): ${setup_err}")
  endif()
endif()

if(DEFINED SETUP_ARGS2)
  string(REPLACE "|" ";" SETUP_ARGS2 "${SETUP_ARGS2}")
  execute_process(COMMAND "${EXE}" ${SETUP_ARGS2} WORKING_DIRECTORY "${WORKDIR}"
                  RESULT_VARIABLE setup_code ERROR_VARIABLE setup_err OUTPUT_QUIET)
  if(NOT setup_code EQUAL 0)
    message(FATAL_ERROR "second setup command failed (${setup_code}): ${setup_err}")
  endif()
endif()

execute_process(COMMAND "${EXE}" ${ARGS}
                WORKING_DIRECTORY "${WORKDIR}"
                RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)

message(STATUS "exit code: ${code}\nstdout: ${out}\nstderr: ${err}")
if(NOT code STREQUAL "${EXPECT_CODE}")
  message(FATAL_ERROR "expected exit code ${EXPECT_CODE}, got ${code}")
endif()
if(DEFINED EXPECT_STDERR AND NOT err MATCHES "${EXPECT_STDERR}")
  message(FATAL_ERROR "stderr does not match: ${EXPECT_STDERR}")
endif()
if(DEFINED EXPECT_STDOUT AND NOT out MATCHES "${EXPECT_STDOUT}")
  message(FATAL_ERROR "stdout does not match: ${EXPECT_STDOUT}")
endif()
if(DEFINED EXPECT_SAME_STDOUT)
  string(REGEX MATCH "${EXPECT_SAME_STDOUT}" same_setup "${setup_out}")
  string(REGEX MATCH "${EXPECT_SAME_STDOUT}" same_test "${out}")
  if(same_test STREQUAL "" OR NOT same_test STREQUAL same_setup)
    message(FATAL_ERROR "stdout differs from the setup run's: '${same_test}' vs '${same_setup}'")
  endif()
endif()
if(DEFINED EXPECT_FILE)
  if(NOT EXISTS "${WORKDIR}/${EXPECT_FILE}")
    message(FATAL_ERROR "output '${EXPECT_FILE}' is missing")
  endif()
  file(READ "${WORKDIR}/${EXPECT_FILE}" file_text)
  if(NOT file_text MATCHES "${EXPECT_FILE_REGEX}")
    message(FATAL_ERROR "'${EXPECT_FILE}' does not match: ${EXPECT_FILE_REGEX}")
  endif()
endif()
if(NOT code EQUAL 0)
  # One line on stderr for a failure.
  string(REGEX MATCHALL "\n" newlines "${err}")
  list(LENGTH newlines n)
  if(NOT n EQUAL 1)
    message(FATAL_ERROR "expected exactly one stderr line on failure, got ${n}")
  endif()
endif()
foreach(p IN LISTS EXPECT_ABSENT)
  if(EXISTS "${WORKDIR}/${p}")
    message(FATAL_ERROR "output '${p}' exists but should not")
  endif()
endforeach()
foreach(p IN LISTS EXPECT_PRESENT)
  if(NOT EXISTS "${WORKDIR}/${p}")
    message(FATAL_ERROR "output '${p}' is missing")
  endif()
endforeach()
file(GLOB_RECURSE leftovers "${WORKDIR}/*.partial*")
if(leftovers)
  message(FATAL_ERROR "temporary files left behind: ${leftovers}")
endif()
