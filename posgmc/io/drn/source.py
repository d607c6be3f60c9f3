"""The DRN text being read: its lines, and the errors that point into it (file, line, column)."""

from __future__ import annotations

from posgmc.errors import ModelFormatError, PosgmcError, SourceSpan, SourceText, UnsupportedError

__all__ = ["DrnText"]


class DrnText:
    """One DRN text, split into lines; keeps the text for error positions."""

    def __init__(self, text: str, file: str | None) -> None:
        self.text = text
        self.file = file
        self.source = SourceText(text, file)
        self.lines = text.split("\n")

    def error(
        self,
        message: str,
        line: int,
        column: int = 1,
        end_column: int | None = None,
        *,
        hint: str | None = None,
        unsupported: bool = False,
    ) -> PosgmcError:
        """The error (to raise) at ``line``, from ``column`` to before ``end_column``."""
        span = SourceSpan(line, column, line, end_column, self.file)
        if unsupported:
            return UnsupportedError(message, span, hint=hint, source=self.source)
        return ModelFormatError(message, span, hint=hint, source=self.source)

    def raw(self, line: int) -> str:
        """Line ``line`` (1-based) without its line ending and trailing blanks."""
        return self.lines[line - 1].rstrip()

    def whole_line_error(self, message: str, line: int, *, hint: str | None = None) -> PosgmcError:
        """The error (to raise) marking line ``line`` from its first to its last non-blank."""
        raw = self.raw(line)
        start = len(raw) - len(raw.lstrip())
        return self.error(message, line, start + 1, max(len(raw), start + 1) + 1, hint=hint)
