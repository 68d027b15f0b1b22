# Checks the module layering that libanalysis/CMakeLists.txt enforces: compiled with
# the include views a stage gets (its own, core's and io's), a stage's source cannot
# find another stage's or pipeline's headers, while its own and core's headers resolve.
# Run by CTest:  cmake -DCXX=<compiler> -DVIEWS=<build>/libanalysis/include-views
#                      -DSOURCE=<repo>/libanalysis -DWORK=<dir> -P check_layering.cmake
set(stages synth piv track profile fit laos sim)
set(failures 0)
file(MAKE_DIRECTORY ${WORK})

# One public header of each module (the first in name order).
foreach(m ${stages} pipeline core)
  file(GLOB hs RELATIVE ${SOURCE}/include ${SOURCE}/include/shearzone/${m}/*.hpp)
  list(SORT hs)
  list(GET hs 0 header_${m})
endforeach()

# preprocess(stage header) -> found (TRUE when the header itself was found)
function(preprocess stage header out)
  set(probe ${WORK}/probe_${stage}.cpp)
  file(WRITE ${probe} "#include \"${header}\"\n")
  execute_process(
    COMMAND ${CXX} -std=c++20 -E -o /dev/null -I${VIEWS}/${stage} -I${VIEWS}/core -I${VIEWS}/io
            ${probe}
    RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_QUIET)
  string(FIND "${err}" "${header}: No such file" missing)
  if(missing EQUAL -1)
    set(${out} TRUE PARENT_SCOPE)
  else()
    set(${out} FALSE PARENT_SCOPE)
  endif()
endfunction()

foreach(s ${stages})
  foreach(t ${stages} pipeline core)
    preprocess(${s} ${header_${t}} found)
    if(t STREQUAL s OR t STREQUAL "core")
      if(NOT found)
        message(SEND_ERROR "${s}: its own or core's header ${header_${t}} is not found")
        math(EXPR failures "${failures} + 1")
      endif()
    elseif(found)
      message(SEND_ERROR "${s} can include ${header_${t}}: stages must not see each other")
      math(EXPR failures "${failures} + 1")
    endif()
  endforeach()
endforeach()
if(failures EQUAL 0)
  list(LENGTH stages n)
  message(STATUS "layering: ${n} stages see only their own, core and io headers")
endif()
