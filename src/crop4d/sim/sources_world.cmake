set(CROP4D_SIM_WORLD_SOURCES world.cc)
set(CROP4D_SIM_WORLD_TESTS world_test.cc)
