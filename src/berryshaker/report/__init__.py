"""Output writers: atomic files, figures, JSON metadata."""
