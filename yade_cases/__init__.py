"""YADE 2023.02a cases for the drum and the shaken box (see README.md)."""
