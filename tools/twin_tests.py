"""Print the pytest node ids of the kernels' float32-against-float64 twin tests, one a line.

``make test-old-driver`` runs them (with the float32 domain and harness tests) on the system's
own lavapipe, after ``make test`` ran the whole suite on the current one. The list is the one
``tests/test_architecture.py`` keeps for every compute entry point.
"""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1] / "tests"


def twin_tests() -> list[str]:
    """The node ids of ``ENTRY_POINT_TWIN_TESTS``, each once, in order."""
    tree = ast.parse((TESTS / "test_architecture.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
                getattr(t, "id", None) == "ENTRY_POINT_TWIN_TESTS" for t in node.targets):
            tests = ast.literal_eval(node.value).values()
            return list(dict.fromkeys(f"tests/{test}" for test in tests))
    raise SystemExit("tests/test_architecture.py has no ENTRY_POINT_TWIN_TESTS")


if __name__ == "__main__":
    print("\n".join(twin_tests()))
