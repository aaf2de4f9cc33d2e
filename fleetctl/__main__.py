from fleetctl.cli import entry

raise SystemExit(entry())
