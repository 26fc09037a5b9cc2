"""The CLI subcommands this plugin implements (entry point group `edged.commands`):
each module declares `COMMAND`, an `edged.subcommand.Subcommand`."""
