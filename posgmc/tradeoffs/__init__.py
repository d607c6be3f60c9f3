"""Trade-offs (issue #15): a property against a swept constant, with verified points."""
