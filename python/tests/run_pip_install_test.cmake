# ctest driver (cmake -P): pip install --no-build-isolation --no-index of
# python/ into a fresh virtual environment (python3 -m venv
# --system-site-packages, so numpy and pytest come from the system), then the
# venv's interpreter imports the module from the venv (not the build tree),
# finds its type stubs and docstrings, and passes the doctest of
# docs/python.md. HBP_CMAKE_BUILD_DIR hands pip this build tree, so the module
# is not compiled a second time (setup.py).
# Inputs: HBP_SOURCE_DIR, HBP_BUILD_DIR, HBP_PYTHON, HBP_WORK_DIR.
file(REMOVE_RECURSE ${HBP_WORK_DIR})
file(MAKE_DIRECTORY ${HBP_WORK_DIR})
set(venv ${HBP_WORK_DIR}/venv)
unset(ENV{PYTHONPATH})
set(ENV{PYTHONDONTWRITEBYTECODE} 1)
set(ENV{PIP_NO_INDEX} 1)  # offline: nothing may be downloaded
set(ENV{PIP_DISABLE_PIP_VERSION_CHECK} 1)
set(ENV{HBP_CMAKE_BUILD_DIR} ${HBP_BUILD_DIR})

function(run what)
  execute_process(COMMAND ${ARGN} WORKING_DIRECTORY ${HBP_WORK_DIR}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  message(STATUS "${what}: ok")
  set(last_out "${out}" PARENT_SCOPE)
endfunction()

run("python3 -m venv --system-site-packages" ${HBP_PYTHON} -m venv --system-site-packages ${venv})
run("pip install --no-build-isolation ./python"
  ${venv}/bin/python -m pip install --no-build-isolation --no-index ${HBP_SOURCE_DIR}/python)
run("import from the venv" ${venv}/bin/python -c [=[
import pathlib, pydoc, sys
import hybrid_broadphase as hbp
where = pathlib.Path(hbp.__file__).resolve()
assert where.is_relative_to(pathlib.Path(sys.prefix).resolve()), (where, sys.prefix)
stub = where.parent / "hybrid_broadphase.pyi"
assert "boxes: numpy.ndarray" in stub.read_text(), stub
text = pydoc.render_doc(hbp.BroadPhase.update, renderer=pydoc.plaintext)
assert "Applies every edit since the last update" in text, text
print(where)
]=])
message(STATUS "${last_out}")
run("doctest of docs/python.md in the venv"
  ${venv}/bin/python -m pytest -q -p no:cacheprovider ${HBP_SOURCE_DIR}/python/tests/test_docs.py)
