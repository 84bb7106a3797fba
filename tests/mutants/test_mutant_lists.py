"""The hand-made shader mutants name code that exists: each snippet is found exactly once in its file, so a
change to a shader that the list was not updated with fails here, in the default suite, and not only when
`make shader-mutants` runs. Negative control: a snippet that is not in its file is reported."""

from __future__ import annotations

from tests.mutants import shader_mutants


def test_every_shader_mutant_snippet_is_found_once():
    assert shader_mutants.check_snippets(shader_mutants.MUTANTS) == []


def test_a_snippet_missing_from_its_file_is_reported():
    file, old, new, desc = shader_mutants.MUTANTS[0]
    problems = shader_mutants.check_snippets([(file, old + " /* not in the file */", new, desc)])
    assert len(problems) == 1 and "found 0 times" in problems[0]
