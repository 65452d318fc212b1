"""Text views of exotune's results: every formatter, one number formatter."""
