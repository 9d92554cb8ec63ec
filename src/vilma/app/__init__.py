"""The application level: the command line, the long-running programs, the demo, batches and the
record/replay/export commands. Everything below it is a library; nothing below imports it."""
