"""Specialisation blocks: WGSL lines kept or removed by a pipeline's override constants.

Override constants alone do not keep a dead branch out of a pipeline's compile time: lavapipe
inlines every function a shader calls, those of branches that the constants disable included,
before it folds the constants away. The renderer's kernel, which holds the layered Bragg,
thin-film and filtered-lighting code paths, took 3.5-5 s to compile for a scene of Lambertian
spheres; without the paths the scene cannot reach, 0.3 s. So a composed source may hold::

    //! if LAYERED && COLOUR_METHOD != 0
    ... lines compiled only where the condition holds
    //! else
    ... lines compiled only where it does not
    //! endif

A condition joins terms with ``||``, each term atoms with ``&&``; an atom is an override
constant's name, optionally negated with ``!`` or compared with ``==`` / ``!=`` to an integer
or boolean literal or a ``const`` declared with one. The constants take the values the
pipeline sets, else the defaults their ``override`` declarations give. Removed lines become
empty lines, so composed line numbers, and with them error locations, do not move. Blocks
nest. Declarations and bindings stay outside blocks: the override constants a pipeline sets
must still be declared.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

_COMMENT_RE = re.compile(r"/\*.*?\*/|//[^\n]*", re.DOTALL)
_DIRECTIVE_RE = re.compile(r"^\s*//!\s*(if|else|endif)\b(.*)$")
_DECLARATION_RE = re.compile(
    r"\b(override|const)\s+(\w+)\s*(?::\s*\w+\s*)?(?:=\s*([^;]+))?;")
_ATOM_RE = re.compile(r"^(!?)\s*(\w+)\s*(?:(==|!=)\s*(\w+))?$")
_LITERAL_RE = re.compile(r"^(true|false|\d+)[ui]?$")


class BlockError(ValueError):
    """A malformed block; ``line`` is the 1-based composed line of the directive."""

    def __init__(self, line: int, message: str):
        super().__init__(message)
        self.line = line


def _literal(text: str) -> int | None:
    match = _LITERAL_RE.match(text.strip())
    if match is None:
        return None
    word = match.group(1)
    return int(word) if word.isdigit() else int(word == "true")


def strip_comments(code: str) -> str:
    """``code`` with its comments blanked; newlines inside block comments are kept, so that
    offsets map to the same lines."""
    return _COMMENT_RE.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), code)


def _declared(code: str, constants: Mapping[str, float | int | bool]) -> tuple[dict, dict]:
    """Override constants with their values (from ``constants``, else their literal defaults;
    None where there is neither, e.g. a default that is an expression), and the ``const``
    declarations with literal values."""
    overrides: dict[str, float | int | bool | None] = {}
    literals: dict[str, int] = {}
    for kind, name, value in _DECLARATION_RE.findall(strip_comments(code)):
        number = _literal(value) if value else None
        if kind == "override":
            overrides[name] = constants.get(name, number)
        elif number is not None:
            literals[name] = number
    return overrides, literals


def _evaluate(condition: str, values: Mapping, literals: Mapping, line: int) -> bool:
    if not condition:
        raise BlockError(line, "`//! if` needs a condition")

    def atom(text: str) -> bool:
        match = _ATOM_RE.match(text.strip())
        if match is None:
            raise BlockError(line, f"cannot read {text.strip()!r} (NAME, !NAME, NAME == 3, "
                                   "NAME != true)")
        negate, name, operator, literal = match.groups()
        if name not in values:
            raise BlockError(line, f"{name!r} is not an override constant of this shader")
        value = values[name]
        if value is None:
            raise BlockError(line, f"{name!r} has neither a value nor a literal default")
        if operator is None:
            result = bool(value)
        else:
            expected = literals.get(literal, _literal(literal))
            if expected is None:
                raise BlockError(line, f"{literal!r} is neither an integer or boolean literal "
                                       "nor a const declared with one")
            result = (value == expected) == (operator == "==")
        return result != bool(negate)

    return any(all(atom(a) for a in term.split("&&")) for term in condition.split("||"))


def specialise(code: str, constants: Mapping[str, float | int | bool]) -> str:
    """``code`` with every block's lines kept or emptied by ``constants`` (see the module).

    Raises
    ------
    BlockError
        On an unbalanced directive, an unknown name or an unreadable condition.
    """
    values, literals = _declared(code, constants)
    lines = code.split("\n")
    # Per open block: the line of its `if`, its condition's value, whether past its `else`.
    stack: list[tuple[int, bool, bool]] = []
    for i, text in enumerate(lines):
        match = _DIRECTIVE_RE.match(text)
        if match is None:
            if not all(holds != past_else for _, holds, past_else in stack):
                lines[i] = ""
            continue
        keyword, rest, line = match.group(1), match.group(2).strip(), i + 1
        if keyword == "if":
            stack.append((line, _evaluate(rest, values, literals, line), False))
        elif not stack:
            raise BlockError(line, f"`//! {keyword}` without `//! if`")
        elif rest:
            raise BlockError(line, f"`//! {keyword}` takes no condition")
        elif keyword == "else":
            start, holds, past_else = stack[-1]
            if past_else:
                raise BlockError(line, "a second `//! else` in one block")
            stack[-1] = (start, holds, True)
        else:
            stack.pop()
    if stack:
        raise BlockError(stack[-1][0], "`//! if` without `//! endif`")
    return "\n".join(lines)

