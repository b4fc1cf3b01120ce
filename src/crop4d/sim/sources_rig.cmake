# The rig side of the simulator: configuration and presets, trajectory, sensor models, the
# orchestration that writes a field folder (sim_config, trajectory, sensor_models, simulator).
set(CROP4D_SIM_RIG_SOURCES sim_config.cc trajectory.cc sensor_models.cc simulator.cc
  imperfections.cc)
set(CROP4D_SIM_RIG_TESTS sim_config_test.cc trajectory_test.cc sensor_models_test.cc
  imperfections_test.cc)
