# ctest driver (cmake -P) of capi_doc_example: the first ```c block of
# docs/c-api.md is compiled as C99 (warnings as errors) against the shared
# library and run; its output must equal the doc's ```text block after it.
# Inputs: HBP_DOC, HBP_C, HBP_C_FLAGS (may be empty), HBP_INCLUDE, HBP_LIBRARY,
# HBP_WORK_DIR.
file(READ ${HBP_DOC} doc)
string(FIND "${doc}" "```c\n" start)
if(start EQUAL -1)
  message(FATAL_ERROR "${HBP_DOC}: no ```c block")
endif()
math(EXPR start "${start} + 5")
string(SUBSTRING "${doc}" ${start} -1 rest)
string(FIND "${rest}" "```" end)
string(SUBSTRING "${rest}" 0 ${end} code)
string(SUBSTRING "${rest}" ${end} -1 rest)
string(FIND "${rest}" "```text\n" out_start)
if(out_start EQUAL -1)
  message(FATAL_ERROR "${HBP_DOC}: no ```text block (the example's output) after the ```c block")
endif()
math(EXPR out_start "${out_start} + 8")
string(SUBSTRING "${rest}" ${out_start} -1 rest)
string(FIND "${rest}" "```" out_end)
string(SUBSTRING "${rest}" 0 ${out_end} expected)

file(REMOVE_RECURSE ${HBP_WORK_DIR})
file(WRITE ${HBP_WORK_DIR}/example.c "${code}")
get_filename_component(libdir ${HBP_LIBRARY} DIRECTORY)
execute_process(COMMAND ${HBP_C} ${HBP_C_FLAGS} -std=c99 -Wall -Wextra -Werror -pedantic -I${HBP_INCLUDE}
    ${HBP_WORK_DIR}/example.c -o ${HBP_WORK_DIR}/example ${HBP_LIBRARY} -Wl,-rpath,${libdir}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the example of ${HBP_DOC} does not compile:\n${out}${err}")
endif()
execute_process(COMMAND ${HBP_WORK_DIR}/example RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the example exited ${rc}:\n${out}${err}")
endif()
if(NOT out STREQUAL expected)
  message(FATAL_ERROR "the example printed\n${out}\nthe doc says\n${expected}")
endif()
message(STATUS "docs/c-api.md example: compiled, ran, printed what the doc says")
