"""ln_bag: MCAP recordings of LN systems."""
