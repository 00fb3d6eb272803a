"""The suite's parallel schedule (conftest.py, pyproject.toml addopts
`--dist loadgroup`): a test that shares a module-scoped fixture carries an
xdist_group mark named for the module and the fixture, and on a pytest-xdist worker its node id carries
the group, so that one worker runs the module's tests and builds the
fixture once.  (When the mark came after xdist's own hook read the marks,
the module fixtures of test_case_answers, each a full case run, were built
on both workers: about 9 minutes of the suite's CPU.)"""
import pytest


@pytest.fixture(scope="module")
def shared():
    return object()


def test_a_module_fixture_groups_its_tests(request, shared):
    marks = [m.args[0] for m in request.node.iter_markers("xdist_group")]
    assert marks == [f"{__name__}:shared"]
    if hasattr(request.config, "workerinput") and request.config.getvalue("loadgroup"):
        assert request.node.nodeid.endswith(f"@{__name__}:shared")
