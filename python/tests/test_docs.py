# SPDX-License-Identifier: MIT
"""docs/python.md's session, run as a doctest: the page shows real outputs."""
import doctest
import pathlib

DOC = pathlib.Path(__file__).resolve().parents[2] / "docs" / "python.md"


def test_python_md_session():
    result = doctest.testfile(str(DOC), module_relative=False, optionflags=doctest.NORMALIZE_WHITESPACE,
                              raise_on_error=False, verbose=False)
    assert result.attempted > 40
    assert result.failed == 0
