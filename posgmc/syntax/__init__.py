"""Front end, first stage: grammar loading, parsing, and the immutable syntax trees (no meaning yet)."""
