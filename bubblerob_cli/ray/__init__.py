"""Ray orchestration of the commands: ``--ray ADDRESS`` of evaluate, record and train."""
