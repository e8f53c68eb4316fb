#!/usr/bin/env python3
"""Write the shipped packed/ and household/ scene YAMLs (pg_sim.scenes.shipped_layouts)."""

from pg_sim.scenes.shipped_layouts import main

if __name__ == "__main__":
    main()
