"""``vecpin workbench``: the day in a browser, a local web page (127.0.0.1 only) over the
same commands as the command line. Each stage runs its command line (the one ``vecpin run``
runs for the session, :func:`vecpin.cli.session.stage_argv`) in the day's folder, and
keeps its choices in the folder's ``session.json``; nothing is computed in the page."""
