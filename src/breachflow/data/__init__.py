"""Data files shipped with breachflow: flood presets (CSV) and example scenarios (TOML)."""
