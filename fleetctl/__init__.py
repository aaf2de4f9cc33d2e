"""`fleetctl`: FleetControl's command line, the one place that wires all parts together."""
