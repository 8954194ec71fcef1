# ctest driver (cmake -P) of core_only_package: the core library configured,
# built and installed with every optional part off and Bullet, CGAL, FCL,
# ODE, Eigen, libpng, CLI11, nlohmann_json, GoogleTest, MPI and Verilator
# invisible; then tests/consumer-core built against the install with
# find_package(hybrid_broadphase) (no components) and with pkg-config, on
# the same hidden tree, and run; and tests/capi/test_capi.c (C99) against the
# installed shared library through hybrid_broadphase-c.pc.
# Inputs: HBP_SOURCE_DIR, HBP_CONSUMER_SOURCE, HBP_WORK_DIR, HBP_GENERATOR, HBP_CXX, HBP_C.
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "failed (${rc}): ${cmd}\n${out}\n${err}")
  endif()
  message(STATUS "ok: ${ARGN}")
  set(last_output "${out}${err}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${HBP_WORK_DIR})
set(prefix ${HBP_WORK_DIR}/prefix)
set(build ${HBP_WORK_DIR}/build)

# pkg-config sees only TBB (and, later, the install): bullet.pc and ode.pc are
# out of reach.
find_program(PKG_CONFIG pkg-config REQUIRED)
execute_process(COMMAND ${PKG_CONFIG} --variable=pcfiledir tbb OUTPUT_VARIABLE tbb_pc_dir
  OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "pkg-config does not know tbb")
endif()
file(MAKE_DIRECTORY ${HBP_WORK_DIR}/visible-pc)
file(COPY ${tbb_pc_dir}/tbb.pc DESTINATION ${HBP_WORK_DIR}/visible-pc)
set(ENV{PKG_CONFIG_LIBDIR} "${prefix}/lib/pkgconfig:${HBP_WORK_DIR}/visible-pc")
unset(ENV{PKG_CONFIG_PATH})
foreach(hidden bullet ode)
  execute_process(COMMAND ${PKG_CONFIG} --exists ${hidden} RESULT_VARIABLE rc)
  if(rc EQUAL 0)
    message(FATAL_ERROR "pkg-config still finds ${hidden}: the test would prove nothing")
  endif()
endforeach()
set(hide_packages)
foreach(p Bullet CGAL fcl Eigen3 ODE PNG CLI11 nlohmann_json GTest benchmark MPI pybind11 Python3 verilator embree)
  list(APPEND hide_packages -DCMAKE_DISABLE_FIND_PACKAGE_${p}=ON)
endforeach()

# The core alone. Unoptimised: the point is what it needs, not its speed.
run(${CMAKE_COMMAND} -S ${HBP_SOURCE_DIR} -B ${build} -G ${HBP_GENERATOR}
    -DCMAKE_CXX_COMPILER=${HBP_CXX} -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-O0 -DHBP_WERROR=ON
    -DHBP_BUILD_TOOLS=OFF -DHBP_BUILD_BENCH=OFF -DHBP_BUILD_BASELINES=OFF -DHBP_BUILD_RTL=OFF
    -DHBP_BUILD_PYTHON=OFF -DHBP_BUILD_MPI=OFF -DHBP_BUILD_TESTS=OFF -DHBP_BUILD_BULLET=OFF -DHBP_CUDA=OFF
    ${hide_packages})
file(READ ${build}/CMakeCache.txt cache)
foreach(dep BULLET_FOUND CGAL_DIR:PATH=/ fcl_DIR:PATH=/ ODE_FOUND PNG_LIBRARY CLI11_DIR:PATH=/ MPI_CXX_FOUND)
  string(FIND "${cache}" "${dep}" at)
  if(NOT at EQUAL -1)
    message(FATAL_ERROR "the core-only configuration looked for or found ${dep}")
  endif()
endforeach()
run(${CMAKE_COMMAND} --build ${build} --parallel 2)
run(${CMAKE_COMMAND} --install ${build} --prefix ${prefix} --component hbp_development)
foreach(f include/hbp/broad_phase.hpp lib/libhybrid_broadphase.a
          lib/cmake/hybrid_broadphase/hybrid_broadphaseConfig.cmake lib/pkgconfig/hybrid_broadphase.pc)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "not installed: ${f}")
  endif()
endforeach()
foreach(f lib/libhbp_bullet.a lib/pkgconfig/hbp_bullet.pc include/hbp/bullet
          lib/cmake/hybrid_broadphase/hybrid_broadphase-bullet-targets.cmake)
  if(EXISTS ${prefix}/${f})
    message(FATAL_ERROR "installed without HBP_BUILD_BULLET: ${f}")
  endif()
endforeach()

# find_package, no components, Bullet and the rest hidden.
run(${CMAKE_COMMAND} -S ${HBP_CONSUMER_SOURCE} -B ${HBP_WORK_DIR}/consumer -G ${HBP_GENERATOR}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_CXX_COMPILER=${HBP_CXX} -DCMAKE_BUILD_TYPE=Release ${hide_packages})
run(${CMAKE_COMMAND} --build ${HBP_WORK_DIR}/consumer)
run(${HBP_WORK_DIR}/consumer/core_consumer)
message(STATUS "${last_output}")
# Asking for the bullet component of this install fails, saying why.
file(MAKE_DIRECTORY ${HBP_WORK_DIR}/ask-bullet)
file(WRITE ${HBP_WORK_DIR}/ask-bullet/CMakeLists.txt
  "cmake_minimum_required(VERSION 3.22)\nproject(ask LANGUAGES CXX)\nfind_package(hybrid_broadphase REQUIRED COMPONENTS bullet)\n")
execute_process(COMMAND ${CMAKE_COMMAND} -S ${HBP_WORK_DIR}/ask-bullet -B ${HBP_WORK_DIR}/ask-bullet/build
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_CXX_COMPILER=${HBP_CXX}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT "${out}${err}" MATCHES "component 'bullet' was not built into this installation")
  message(FATAL_ERROR "find_package(... COMPONENTS bullet) on a core-only install: rc ${rc}\n${out}\n${err}")
endif()

# pkg-config
run(${PKG_CONFIG} --cflags --libs hybrid_broadphase)
string(STRIP "${last_output}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
run(${HBP_CXX} -O1 ${HBP_CONSUMER_SOURCE}/main.cpp -o ${HBP_WORK_DIR}/core_consumer_pc ${flags})
run(${HBP_WORK_DIR}/core_consumer_pc)
message(STATUS "${last_output}")

# The C API from the install: the C99 test program against the shared library
# through hybrid_broadphase-c.pc.
if(HBP_C AND EXISTS ${prefix}/lib/pkgconfig/hybrid_broadphase-c.pc)
  run(${PKG_CONFIG} --cflags --libs hybrid_broadphase-c)
  string(STRIP "${last_output}" flags)
  separate_arguments(flags UNIX_COMMAND "${flags}")
  run(${HBP_C} -std=c99 -Wall -Wextra -Werror -pedantic -O1 ${HBP_SOURCE_DIR}/tests/capi/test_capi.c
      -o ${HBP_WORK_DIR}/test_capi_installed ${flags} -lm -Wl,-rpath,${prefix}/lib)
  run(${HBP_WORK_DIR}/test_capi_installed 3 10)
  message(STATUS "${last_output}")
  execute_process(COMMAND readelf -d ${HBP_WORK_DIR}/test_capi_installed OUTPUT_VARIABLE needed)
  if(NOT needed MATCHES "libhybrid_broadphase\\.so\\.0\\.1")
    message(FATAL_ERROR "the C program does not load libhybrid_broadphase.so.0.1:\n${needed}")
  endif()
endif()
