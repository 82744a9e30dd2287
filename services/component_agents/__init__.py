"""Smart-component agents: one per manifest component, each verifying its own placement (paper §4.4–4.5)."""
