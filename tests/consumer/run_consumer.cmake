# ctest -P script: install the built furrow into a staging prefix, configure + build the consumer against it,
# run it.
foreach(v FURROW_BINARY_DIR FURROW_CONSUMER_SOURCE WORK_DIR)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "${v} not set")
  endif()
endforeach()
file(REMOVE_RECURSE "${WORK_DIR}")
set(prefix "${WORK_DIR}/prefix")
execute_process(COMMAND ${CMAKE_COMMAND} --install "${FURROW_BINARY_DIR}" --prefix "${prefix}" RESULT_VARIABLE rc OUTPUT_QUIET)
if(rc)
  message(FATAL_ERROR "install failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S "${FURROW_CONSUMER_SOURCE}" -B "${WORK_DIR}/build" -DCMAKE_PREFIX_PATH=${prefix}
  -DCMAKE_BUILD_TYPE=Release RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configuring the consumer failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build "${WORK_DIR}/build" RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building the consumer failed: ${rc}")
endif()
execute_process(COMMAND "${WORK_DIR}/build/consumer" "${WORK_DIR}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc OR NOT out MATCHES "consumer ok" OR NOT EXISTS "${WORK_DIR}/furry_sphere.glb")
  message(FATAL_ERROR "the consumer failed: ${rc} ${out} ${err}")
endif()
message(STATUS "consumer built against the installed package and ran: ${out}")

# The installed command runs its demo from any folder: it finds the bundled models beside itself
# (<prefix>/share/furrow/models), not in the source tree it was built from.
file(MAKE_DIRECTORY "${WORK_DIR}/elsewhere")
execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=FURROW_MODELS "${prefix}/bin/furrow" demo -o demo_out --ssaa 1 -q
  WORKING_DIRECTORY "${WORK_DIR}/elsewhere" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc OR NOT EXISTS "${WORK_DIR}/elsewhere/demo_out/scene_shaded.png")
  message(FATAL_ERROR "the installed furrow demo failed from ${WORK_DIR}/elsewhere: ${rc} ${err}")
endif()
# ... and names no folder of the machine it was built on (debug information, which names the sources by
# design, aside).
execute_process(COMMAND objcopy --strip-debug "${prefix}/bin/furrow" "${WORK_DIR}/furrow.stripped" RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "objcopy --strip-debug failed: ${rc}")
endif()
file(READ "${WORK_DIR}/furrow.stripped" binary HEX)
string(HEX "${FURROW_SOURCE_DIR}" source_hex)
string(FIND "${binary}" "${source_hex}" at)
if(NOT at EQUAL -1)
  message(FATAL_ERROR "the installed furrow binary contains the source path ${FURROW_SOURCE_DIR}")
endif()
message(STATUS "the installed furrow demo ran from ${WORK_DIR}/elsewhere")
