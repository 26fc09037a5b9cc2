"""The CLI subcommands this plugin implements (entry point group `edged.commands`).

Each module has `main(args) -> int` reading the Namespace that `edged.cli` defines;
exit codes follow DESIGN §4 (0 ok, 1 runtime failure, 2 bad usage).
"""
