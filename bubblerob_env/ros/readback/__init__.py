"""Reading bags back: what a bag holds (summary, episodes) and replay against a re-simulation."""
