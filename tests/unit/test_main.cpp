#include <OpenMesh/Core/System/omstream.hh>
#include <gtest/gtest.h>

int main(int argc, char** argv) {
  // Faces OpenMesh refuses are reported by touchmend itself; keep OpenMesh's own log quiet.
  omerr().disable();
  omout().disable();
  omlog().disable();
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
