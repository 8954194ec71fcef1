# ctest driver (cmake -P): installs the build tree to a fresh prefix, then
# builds tests/consumer against it twice, with find_package(hybrid_broadphase)
# and with pkg-config (hbp_bullet.pc), and runs both programs.
# Inputs: HBP_BUILD_DIR, HBP_CONSUMER_SOURCE, HBP_WORK_DIR, HBP_GENERATOR, HBP_CXX.
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "failed (${rc}): ${cmd}\n${out}\n${err}")
  endif()
  message(STATUS "ok: ${ARGN}")
  set(last_output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${HBP_WORK_DIR})
set(prefix ${HBP_WORK_DIR}/prefix)
run(${CMAKE_COMMAND} --install ${HBP_BUILD_DIR} --prefix ${prefix} --component hbp_development)
foreach(f include/hbp/bullet/broadphase_adapter.hpp include/hbp/hybrid_broadphase.hpp
          lib/libhbp_bullet.a lib/libhybrid_broadphase.a
          lib/cmake/hybrid_broadphase/hybrid_broadphaseConfig.cmake
          lib/pkgconfig/hybrid_broadphase.pc lib/pkgconfig/hbp_bullet.pc)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "not installed: ${f}")
  endif()
endforeach()

# find_package
run(${CMAKE_COMMAND} -S ${HBP_CONSUMER_SOURCE} -B ${HBP_WORK_DIR}/build -G ${HBP_GENERATOR}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_CXX_COMPILER=${HBP_CXX} -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${HBP_WORK_DIR}/build)
run(${HBP_WORK_DIR}/build/consumer)
message(STATUS "${last_output}")

# pkg-config
find_program(PKG_CONFIG pkg-config REQUIRED)
set(ENV{PKG_CONFIG_PATH} ${prefix}/lib/pkgconfig)
run(${PKG_CONFIG} --cflags --libs hbp_bullet)
string(STRIP "${last_output}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
run(${HBP_CXX} -std=c++20 -O1 ${HBP_CONSUMER_SOURCE}/main.cpp -o ${HBP_WORK_DIR}/consumer_pc ${flags})
run(${HBP_WORK_DIR}/consumer_pc)
message(STATUS "${last_output}")
