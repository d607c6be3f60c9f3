"""What every group of parse actions shares: the file name, the first conversion error, and
spans of single tokens (see :class:`posgmc.syntax.transformer.AstBuilder`)."""

from __future__ import annotations

import re

from lark import Token

from posgmc.errors import ParseError, PosgmcError, SourceSpan

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


class ActionBase:
    """State and helpers of the parse actions (one instance per parse)."""

    def __init__(self, *, file: str | None) -> None:
        self.file = file
        self.error: PosgmcError | None = None

    def _fail(self, error: PosgmcError) -> None:
        """Keep the first conversion error; the parse goes on (see the class docstring)."""
        if self.error is None:
            self.error = error

    # --- spans ---------------------------------------------------------------------------------

    def _tspan(self, token: Token) -> SourceSpan:
        line, column = token.line or 0, token.column or 0
        return SourceSpan(line, column, token.end_line, token.end_column, self.file)

    def _quoted_identifier(self, token: Token, what: str) -> str:
        name = str(token.value)[1:-1]
        if not _IDENTIFIER.match(name):
            self._fail(
                ParseError(
                    f"{what} names must be identifiers (letters, digits, '_'), not {token.value}",
                    self._tspan(token),
                )
            )
        return name
