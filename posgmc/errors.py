"""The one error hierarchy of posgmc.

Every error a user can cause carries a :class:`SourceSpan` pointing into the model or property text,
and renders as ``file:line:col: error: message`` followed by the offending line and a caret, then a
hint saying what to do. Invalid input (:class:`InputError` and subclasses) is kept apart from input
that is valid but not supported by this build (:class:`UnsupportedError`).
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class SourceSpan:
    """A region of a source text; lines and columns are 1-based, ``end_column`` exclusive."""

    line: int
    column: int
    end_line: int | None = None
    end_column: int | None = None
    file: str | None = None

    def __str__(self) -> str:
        return f"{self.file or '<input>'}:{self.line}:{self.column}"


@dataclass(frozen=True)
class SourceText:
    """The text an error points into, kept so that diagnostics can show the offending line."""

    text: str
    file: str | None = None

    def line(self, number: int) -> str | None:
        """Line ``number`` (1-based), lines separated by "\n" only, as the lexer and PRISM count
        them (``str.splitlines`` would also split at form feeds and U+0085)."""
        lines = self.text.split("\n")
        if 1 <= number <= len(lines):
            return lines[number - 1].removesuffix("\r")
        return None


class PosgmcError(Exception):
    """Base class of every error posgmc raises on purpose."""

    kind = "error"  # the word render() puts after the position

    def __init__(
        self,
        message: str,
        span: SourceSpan | None = None,
        *,
        hint: str | None = None,
        source: SourceText | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.span = span
        self.hint = hint
        self.source = source

    def with_source(self, source: SourceText) -> PosgmcError:
        """Attach the source text (and file name, if the span has none) for rendering."""
        if self.source is None:
            self.source = source
        if self.span is not None and self.span.file is None and source.file is not None:
            self.span = SourceSpan(
                self.span.line,
                self.span.column,
                self.span.end_line,
                self.span.end_column,
                source.file,
            )
        return self

    def render(self) -> str:
        """``file:line:col: error: message``, the source line with a caret, and the hint."""
        kind = self.kind
        if self.span is None:
            head = f"{kind}: {self.message}"
            return head + (f"\n  hint: {self.hint}" if self.hint else "")
        out = [f"{self.span}: {kind}: {self.message}"]
        text = self.source.line(self.span.line) if self.source is not None else None
        if text is not None:
            width = 1
            if self.span.end_line == self.span.line and self.span.end_column is not None:
                width = max(1, self.span.end_column - self.span.column)
            prefix = text[: self.span.column - 1].expandtabs(4)
            out.append("  " + text.expandtabs(4))
            out.append("  " + " " * len(prefix) + "^" + "~" * (width - 1))
        if self.hint:
            out.append(f"  hint: {self.hint}")
        return "\n".join(out)

    def __str__(self) -> str:
        if self.span is None:
            return self.message
        return f"{self.span}: {self.message}"


class InputError(PosgmcError):
    """The input is invalid: the user must change the model, the properties or the options."""


class ParseError(InputError):
    """The text does not follow the grammar."""


class SemanticError(InputError):
    """The text parses but means nothing: undefined names, type errors, ranges, ownership."""


class ConstantError(InputError):
    """A constant is undefined where a value is needed, defined twice, or given a bad value."""


class BuildError(InputError):
    """The model is invalid in a way only exploration shows (e.g. probabilities not summing
    to 1)."""


class ModelFormatError(InputError):
    """An explicit model file (DRN, ...) is malformed."""


class DialectWarning(PosgmcError):
    """Input that PRISM refuses but Storm (and so PAYNT) accepts, read as Storm reads it. Never
    raised: collected beside the errors and shown as a positioned warning; ``--strict`` turns
    each into a :class:`SemanticError`."""

    kind = "warning"


class UnsupportedError(PosgmcError):
    """The input is valid but asks for something this build does not do; the hint says what to do
    instead."""


class LimitError(PosgmcError):
    """A resource limit (states, memory, time) set by the user or by default was reached."""


class WorkerError(PosgmcError):
    """A worker that ran part of the computation (a process of the local pool, an actor on a
    Ray cluster) died, and retrying did not help; the message names the task."""


@dataclass
class Diagnostics:
    """Collects several errors so that ``lint`` can report all of them at once."""

    errors: list[PosgmcError] = field(default_factory=list)

    def add(self, error: PosgmcError) -> None:
        self.errors.append(error)

    def __bool__(self) -> bool:
        return bool(self.errors)


class MultipleErrors(InputError):
    """Several input errors found in one pass; ``errors`` holds them in source order."""

    def __init__(self, errors: list[PosgmcError]) -> None:
        first = errors[0]
        super().__init__(first.message, first.span, hint=first.hint, source=first.source)
        self.errors = errors

    def render(self) -> str:
        return "\n".join(e.render() for e in self.errors)
