"""What the test packages share: waiting for a condition (`waiting`), the project's files and
vectors (`paths`), free ports (`network`), simulators in processes of their own
(`processes`, `typed`), buses behind a master (`buses`), the web page's server and browser
(`web`), one adapter per face for the attack suite over all of them (`faces`), and what only
some systems have, with the marks that skip the tests needing it elsewhere (`posix`).

conftest.py files hold fixtures only; the helpers they and the tests use live here."""
