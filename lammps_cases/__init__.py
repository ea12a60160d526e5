"""The drum and shaken-box scenes in LAMMPS (Debian 12: the 29 Sep 2021 stable
release), from the same scene files as the native engine, writing the common
HDF5 schema. See README.md and docs/model_mapping.md."""
