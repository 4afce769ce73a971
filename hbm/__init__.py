"""hbm package."""
