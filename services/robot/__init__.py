"""Robot task execution and navigation: occupancy grid, A* global planner, DWA local planner, MCL."""
