"""Specialisation blocks: WGSL lines kept or removed by a pipeline's override constants.

Override constants alone do not keep a dead branch out of a pipeline's compile time: lavapipe
inlines every function a shader calls, those of branches that the constants disable included,
before it folds the constants away. The renderer's kernel, which holds the layered Bragg,
thin-film and filtered-lighting code paths, took 3.5-5 s to compile for a scene of Lambertian
spheres; without the paths the scene cannot reach, under 0.1 s. So a composed source may hold::

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
nest. A directive (or include) line inside a block comment, which nests in WGSL, is comment
text. Declarations, bindings and ``//! include`` lines stay outside blocks: the override
constants a pipeline sets must still be declared, and includes are resolved (each file once)
before any block is.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

_COMMENT_OPEN_RE = re.compile(r"//|/\*")
_BLOCK_TOKEN_RE = re.compile(r"/\*|\*/")
_INDENT_RE = re.compile(r"[ \t]*")
_DIRECTIVE_RE = re.compile(r"^\s*//!\s*(\w*)(.*)$")
_DECLARATION_RE = re.compile(r"(?:@id\s*\(\s*(\d+)\s*\)\s*)?\b(override|const)\s+(\w+)\s*"
                             r"(?::\s*\w+\s*)?(?:=\s*([^;]+))?;")
_ATOM_RE = re.compile(r"^(?:!\s*(\w+)|(\w+)\s*(?:(==|!=)\s*(\w+))?)$")
_LITERAL_RE = re.compile(r"^(?:(true|false)|(\d+)[ui]?)$")


class BlockError(ValueError):
    """A malformed block; ``line`` is the 1-based composed line of the directive."""

    def __init__(self, line: int, message: str):
        super().__init__(message)
        self.line = line


def _literal(text: str) -> int | None:
    match = _LITERAL_RE.match(text.strip())
    if match is None:
        return None
    boolean, integer = match.groups()
    return int(integer) if boolean is None else int(boolean == "true")


def comment_spans(code: str) -> list[tuple[int, int]]:
    """``(start, end)`` offsets of the comments in ``code``, in order: from ``//`` to the end
    of its line, and from ``/*`` to its matching ``*/`` (block comments nest in WGSL; an
    unclosed one runs to the end)."""
    spans = []
    position = 0
    while (opening := _COMMENT_OPEN_RE.search(code, position)) is not None:
        if opening.group(0) == "//":
            end = code.find("\n", opening.start())
            end = len(code) if end < 0 else end
        else:
            depth, end = 1, len(code)
            cursor = opening.end()
            while (token := _BLOCK_TOKEN_RE.search(code, cursor)) is not None:
                depth += 1 if token.group(0) == "/*" else -1
                cursor = token.end()
                if depth == 0:
                    end = cursor
                    break
        spans.append((opening.start(), end))
        position = end
    return spans


def strip_comments(code: str) -> str:
    """``code`` with its comments blanked; newlines inside block comments are kept, so that
    offsets map to the same lines."""
    parts, last = [], 0
    for start, end in comment_spans(code):
        parts += [code[last:start], re.sub(r"[^\n]", " ", code[start:end])]
        last = end
    parts.append(code[last:])
    return "".join(parts)


def lines_in_block_comments(code: str) -> set[int]:
    """0-based indices of the lines whose first non-blank character lies inside a block
    comment: a ``//!`` line there is comment text, not a directive."""
    inside: set[int] = set()
    if "/*" not in code:
        return inside
    line_starts = [0] + [match.end() for match in re.finditer("\n", code)]
    for start, end in comment_spans(code):
        if not code.startswith("/*", start):
            continue
        for line in range(code.count("\n", 0, start), code.count("\n", 0, end) + 1):
            first_character = _INDENT_RE.match(code, line_starts[line]).end()
            if start < first_character < end:
                inside.add(line)
    return inside


def _declared(code: str, constants: Mapping[str, float | int | bool]) -> tuple[dict, dict]:
    """Override constants with their values (from ``constants`` by name or ``@id``, else their
    literal defaults; None where there is neither, e.g. a default that is an expression), and
    the ``const`` declarations with integer or boolean literal values (a name declared with
    two values, in two functions, is left out)."""
    overrides: dict[str, float | int | bool | None] = {}
    literals: dict[str, int | None] = {}
    for number_id, kind, name, value in _DECLARATION_RE.findall(strip_comments(code)):
        number = _literal(value) if value else None
        if kind == "override":
            overrides[name] = constants.get(name, constants.get(number_id, number))
        elif number is not None:
            literals[name] = number if literals.get(name, number) == number else None
    return overrides, {k: v for k, v in literals.items() if v is not None}


def _evaluate(condition: str, values: Mapping, literals: Mapping, line: int) -> bool:
    if not condition:
        raise BlockError(line, "`//! if` needs a condition")

    def atom(text: str) -> bool:
        match = _ATOM_RE.match(text.strip())
        if match is None:
            raise BlockError(line, f"cannot read {text.strip()!r} (NAME, !NAME, NAME == 3, "
                                   "NAME != true)")
        negated, name, operator, literal = match.groups()
        name = negated or name
        if name not in values:
            raise BlockError(line, f"{name!r} is not an override constant of this shader")
        value = values[name]
        if value is None:
            raise BlockError(line, f"{name!r} is not set and its default is not an integer "
                                   "or boolean literal")
        if operator is None:
            return bool(value) != bool(negated)
        expected = literals.get(literal, _literal(literal))
        if expected is None:
            raise BlockError(line, f"{literal!r} is neither an integer or boolean literal nor "
                                   "a const declared with one")
        return (value == expected) == (operator == "==")

    # Every atom is read, so that a typo fails whatever the constants.
    terms = [[atom(a) for a in term.split("&&")] for term in condition.split("||")]
    return any(all(term) for term in terms)


def specialise(code: str, constants: Mapping[str, float | int | bool]) -> str:
    """``code`` with every block's lines kept or emptied by ``constants`` (see the module).

    Raises
    ------
    BlockError
        On an unbalanced directive, an unknown name or an unreadable condition.
    """
    values, literals = _declared(code, constants)
    lines = code.split("\n")
    commented = lines_in_block_comments(code)
    # Per open block: the line of its `if`, its condition's value, whether past its `else`.
    stack: list[tuple[int, bool, bool]] = []
    for i, text in enumerate(lines):
        match = None if i in commented else _DIRECTIVE_RE.match(text)
        if match is None:
            if not all(holds != past_else for _, holds, past_else in stack):
                lines[i] = ""
            continue
        keyword, rest, line = match.group(1), match.group(2).strip(), i + 1
        if keyword not in ("if", "else", "endif"):
            raise BlockError(line, f"unknown directive `//! {keyword}` (if, else, endif; "
                                   "includes are resolved before blocks)")
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

