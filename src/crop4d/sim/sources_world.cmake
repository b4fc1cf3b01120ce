set(CROP4D_SIM_WORLD_SOURCES
  world.cc
  textures.cc
  plant_mesh.cc
  gl_context.cc
  renderer.cc)
set(CROP4D_SIM_WORLD_TESTS
  world_test.cc
  textures_test.cc
  plant_mesh_test.cc)
# Tests that render images or simulate whole sessions (not unit tests).
set(CROP4D_SIM_RENDERED_TESTS renderer_test.cc simulator_test.cc)
