// Ports (pure): names of types and modes, compatibility, the PortSet's errors, choosing a transport, sizes.
#include "host/port.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace {

TEST(PortTest, NamesTypesAndModes) {
  EXPECT_EQ(dca::to_string(dca::PortType::VectorX), "vectorx");
  EXPECT_EQ(dca::port_type_from("vector"), dca::PortType::Vector);
  EXPECT_FALSE(dca::port_type_from("matrix"));
  EXPECT_EQ(dca::mode_from("pull"), dca::Mode::Pull);
  EXPECT_FALSE(dca::mode_from("poll"));
}

TEST(PortTest, CompatibilityChecksTypeAndSize) {
  EXPECT_EQ(dca::compatibility_error(dca::vector_port("A", 3), dca::vector_port("B", 3)), "");
  EXPECT_EQ(dca::compatibility_error(dca::vector_port("A", 3), dca::vector_port("B", 4)),
            "output 'A' is vector[3] but input 'B' is vector[4]");
  EXPECT_EQ(dca::compatibility_error(dca::scalar_port("A"), dca::vectorx_port("B")),
            "output 'A' is scalar but input 'B' is vectorx");
}

TEST(PortTest, UnknownPortErrorListsTheValidNames) {
  dca::PortSet ps;
  ps.add_input(dca::scalar_port("In1"));
  ps.add_input(dca::vector_port("Force", 6, "N"));
  EXPECT_EQ(ps.no_such_input("compliant", "In2"), "no input 'In2' on compliant; inputs are: In1, Force");
  EXPECT_EQ(ps.no_such_output("compliant", "Out"), "no output 'Out' on compliant; it has no outputs");
  EXPECT_THROW(ps.add_input(dca::scalar_port("In1")), std::invalid_argument);
}

TEST(PortTest, ChoosesTransportFromWhereTheEndsLive) {
  const dca::Location there{"b", "/tmp/x.sock", "127.0.0.1:9"};
  EXPECT_EQ(dca::choose_transport("a", true, there), dca::Transport::InProcess);
  EXPECT_EQ(dca::choose_transport("b", false, there), dca::Transport::Unix);
  EXPECT_EQ(dca::choose_transport("a", false, there), dca::Transport::Tcp);
}

TEST(PortTest, WrongSizeSampleIsRejectedAndCounted) {
  dca::Output out(dca::vector_port("Out", 3));
  EXPECT_FALSE(out.write(Eigen::VectorXd::Zero(2)));
  EXPECT_FALSE(out.write(1.0));
  EXPECT_TRUE(out.write(Eigen::Vector3d(1, 2, 3)));
  EXPECT_EQ(out.stats().rejected, 2u);
  EXPECT_EQ(out.stats().samples, 1u);
}

}  // namespace
