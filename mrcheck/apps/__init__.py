"""What a planner runs: batch export, the review tool, discrepancies, deviation."""
