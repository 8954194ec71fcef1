# ctest driver (cmake -P): cmake --install of the Python component under a
# fresh prefix (the module and its type stubs), then /usr/bin/python3 imports
# the module from there (and not from the build tree) and finds one pair.
# Inputs: HBP_BUILD_DIR, HBP_PYTHON, HBP_PYTHON_INSTALL_DIR, HBP_WORK_DIR, HBP_VERSION.
file(REMOVE_RECURSE ${HBP_WORK_DIR})
set(prefix ${HBP_WORK_DIR}/prefix)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${HBP_BUILD_DIR} --prefix ${prefix} --component hbp_python
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc}):\n${out}\n${err}")
endif()
file(GLOB module ${prefix}/${HBP_PYTHON_INSTALL_DIR}/hybrid_broadphase*.so)
if(NOT module)
  message(FATAL_ERROR "no hybrid_broadphase*.so under ${prefix}/${HBP_PYTHON_INSTALL_DIR}:\n${out}")
endif()
if(NOT EXISTS ${prefix}/${HBP_PYTHON_INSTALL_DIR}/hybrid_broadphase.pyi)
  message(FATAL_ERROR "the type stubs hybrid_broadphase.pyi are not beside the module in ${prefix}/${HBP_PYTHON_INSTALL_DIR}")
endif()
set(ENV{PYTHONPATH} ${prefix}/${HBP_PYTHON_INSTALL_DIR})
execute_process(COMMAND ${HBP_PYTHON} -c [=[
import sys, numpy as np, hybrid_broadphase as hbp
assert hbp.__file__.startswith(sys.argv[1]), hbp.__file__
assert hbp.__version__ == sys.argv[2], hbp.__version__
boxes = np.array([[0, 0, 0, 1, 1, 1], [1, 1, 1, 2, 2, 2], [3, 3, 3, 4, 4, 4]], np.float32)
assert hbp.find_pairs(boxes).tolist() == [[0, 1]]
print("imported", hbp.__file__)
]=] ${prefix} ${HBP_VERSION}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "import from the installed prefix failed (${rc}):\n${out}\n${err}")
endif()
message(STATUS "${out}")
