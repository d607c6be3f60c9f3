"""Strategy synthesis for partially observable games (finite-state strategies)."""
