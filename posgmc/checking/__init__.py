"""Property checking on explicit models: state formulas, query dispatch to engines, results."""
