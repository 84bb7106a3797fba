"""The iblcheck command line: `entry.py` starts it, `main.py` parses and runs the commands."""
