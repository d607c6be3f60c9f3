"""The compiler: vectorized exploration of a FlatModel into an ExplicitModel."""
