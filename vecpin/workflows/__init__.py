"""Workflows: the jobs the command line runs, as functions a script can call.

Each returns a result object with the numbers (and a ``lines()`` or ``table()`` method
for the text the command prints); none of them parses arguments or prints.
"""
