"""The CLI subcommands this plugin implements (entry point group `edged.commands`).

Each module declares `COMMAND`, an `edged.subcommand.Subcommand`: its arguments and
its `main(args, registry) -> int`; exit codes follow DESIGN §4 (0 ok, 1 runtime
failure, 2 bad usage).
"""
