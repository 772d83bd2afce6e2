"""Virtual test rigs: simulated versions of the seeds' experiments that write measured-data
files (one module per plant, e.g. :mod:`hydro_envs.rigs.ls_compensator`)."""
