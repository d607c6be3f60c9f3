"""Where PRISM and Storm read the language differently, and which reading applies.

Storm (and PAYNT, which parses with Storm) accepts some files that PRISM refuses. posgmc reads
them as Storm does and says so with a positioned :class:`~posgmc.errors.DialectWarning` that
names PRISM's rule; ``strict`` keeps PRISM's reading, and each of them is an error instead.

The differences, each measured with Storm 2.0 and checked against its source:

* ``int / int`` is an int in Storm's type system (``Type::divide`` keeps the larger operand
  type), so ``y' = SIZE/2 + 1`` may update an int variable and ``init N/2`` may initialise one.
  PRISM's ``/`` always gives a double, which an int variable does not take. What Storm does with
  a value that is not whole: it evaluates the expression in double precision and truncates
  toward zero (``7/2`` gives 3, ``-7/2`` gives -3, and ``29/100*100`` gives 28 because the
  double is 28.999...). posgmc takes a whole value as it is and refuses any other value with the
  position of the expression and the state, rather than reproduce that rounding.
* A label and a named observable may share a name: Storm keeps labels and observations apart.
  PRISM lets a property use a named observable as a label, so the names must differ there.
  posgmc keeps the label under that name in properties, and the observable as an observation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from posgmc.errors import DialectWarning, PosgmcError, SemanticError, SourceSpan

__all__ = ["Dialect", "INT_DIVISION", "LABEL_OBSERVABLE"]

INT_DIVISION = (
    'PRISM\'s rule: "/" gives a double, which an int variable does not take',
    "int/int is an int; a value that is not whole is an error when the model is built",
)
LABEL_OBSERVABLE = (
    "PRISM's rule: properties may use a named observable as a label, so the names must differ",
    "labels and observables are apart; properties see the label",
)


@dataclass(frozen=True)
class Dialect:
    """The reading in force (``strict``: PRISM's) and the warnings met so far."""

    strict: bool = False
    warnings: list[PosgmcError] = field(default_factory=list)

    def storm_only(
        self,
        errors: list[PosgmcError],
        message: str,
        span: SourceSpan | None,
        rule: tuple[str, str],
    ) -> None:
        """``message`` describes input that only Storm accepts; ``rule`` is (PRISM's rule,
        Storm's meaning). Strict: an error naming PRISM's rule; otherwise a warning."""
        prism, storm = rule
        if self.strict:
            errors.append(
                SemanticError(
                    f"{message} ({prism})",
                    span,
                    hint=f"without --strict posgmc reads it as Storm does ({storm})",
                )
            )
        else:
            self.warnings.append(
                DialectWarning(
                    f"{message}: accepted as in Storm ({storm}); {prism}",
                    span,
                    hint="--strict keeps PRISM's rule",
                )
            )
