# HBP_CUDA = AUTO|ON|OFF: enables CUDA when a compiler is found (AUTO) or
# required (ON), for sm_90 (H100/H200) plus its PTX.
# CMake 3.25 does not know nvcc 13's C++20 flag: it is set here.
# Sets HBP_HAVE_CUDA.
set(HBP_HAVE_CUDA OFF)
if(NOT HBP_CUDA STREQUAL "OFF")
  include(CheckLanguage)
  check_language(CUDA)
  if(CMAKE_CUDA_COMPILER)
    if(NOT DEFINED CMAKE_CUDA_ARCHITECTURES)
      set(CMAKE_CUDA_ARCHITECTURES "90-real;90-virtual")
    endif()
    enable_language(CUDA)
    set(CMAKE_CUDA20_STANDARD_COMPILE_OPTION "-std=c++20")
    set(CMAKE_CUDA20_EXTENSION_COMPILE_OPTION "-std=c++20")
    set(HBP_HAVE_CUDA ON)
  elseif(HBP_CUDA STREQUAL "ON")
    message(FATAL_ERROR "HBP_CUDA=ON but no CUDA compiler was found (nvcc on the PATH or CMAKE_CUDA_COMPILER)")
  endif()
endif()
message(STATUS "HBP_CUDA=${HBP_CUDA}: hbp::cuda ${HBP_HAVE_CUDA}")
