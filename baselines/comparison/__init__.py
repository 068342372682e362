"""Methods side by side at matched budgets: `compare` reads RL and evolution runs into curves, tables and plots
(robot-steps and CPU-seconds), `stats` the IQM with bootstrap intervals and Fisher's exact test."""
