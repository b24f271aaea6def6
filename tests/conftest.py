"""Test session set-up shared by every test module."""

import signal

# The tests that interrupt a render or the compare server send SIGINT as a
# user's Ctrl-C would.  A test run started as a background job of a
# non-interactive shell (``cmd &``) inherits SIGINT ignored, the shell's rule
# for background jobs, and keeps it ignored (Python installs its Ctrl-C
# handler only where SIGINT is not ignored at start-up), as would every
# ``synth`` process it starts: those tests then failed, testing the shell
# instead of the program (synth.io.interrupt keeps an ignored signal
# ignored, on purpose).  So the session takes Ctrl-C as an interactive one
# does; its children inherit the default disposition at exec.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
