"""Helpers every layer may use: argument validation (`validate`), atomic result files
(`files`), which hoprover a process runs (`buildinfo`) and the old module paths
(`moved`). Nothing here knows the rover."""
