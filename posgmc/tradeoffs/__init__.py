"""Trade-offs: a property against a swept constant, with verified points."""
