# ctest driver (cmake -P) of capi_doc_example: the first ```c block of
# docs/c-api.md is compiled as C99 (warnings as errors) against the shared
# library and run; its output must equal the doc's ```text block after it.
# Inputs: HBP_DOC, HBP_C, HBP_C_FLAGS (may be empty), HBP_INCLUDE, HBP_LIBRARY,
# HBP_WORK_DIR.
# The body of the first block of `text` opened by `fence` (its opening line,
# newline included) into <body_var>, and the text from the block's closing
# fence on into <rest_var>; no such block: fails saying `missing`.
function(fenced_block text fence missing body_var rest_var)
  string(FIND "${text}" "${fence}" start)
  if(start EQUAL -1)
    message(FATAL_ERROR "${HBP_DOC}: ${missing}")
  endif()
  string(LENGTH "${fence}" skip)
  math(EXPR start "${start} + ${skip}")
  string(SUBSTRING "${text}" ${start} -1 rest)
  string(FIND "${rest}" "```" end)
  string(SUBSTRING "${rest}" 0 ${end} body)
  string(SUBSTRING "${rest}" ${end} -1 rest)
  set(${body_var} "${body}" PARENT_SCOPE)
  set(${rest_var} "${rest}" PARENT_SCOPE)
endfunction()

file(READ ${HBP_DOC} doc)
fenced_block("${doc}" "```c\n" "no ```c block" code rest)
fenced_block("${rest}" "```text\n" "no ```text block (the example's output) after the ```c block" expected rest)

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
