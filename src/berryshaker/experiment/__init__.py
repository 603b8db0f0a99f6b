"""Experiments: orthogonal designs, field sheets, analysis of tests (range analysis, ANOVA, regression), model agreement, named clearance sets."""
