"""The processes of a deployment, one package ("wing") each: transport (below every other wing),
recording, model and worker, learner, launcher. docs/ARCHITECTURE.md draws them; the import
contracts in pyproject.toml keep each wing on the ones below it."""
