// A capture daemon on the simulated rig whose control server a test starts
// on its socket and on a loopback port (the kernel's pick), with a known
// bearer token.
#pragma once

#include <string>

#include "acquisition/control_server.h"
#include "tests/acquisition/simulated_daemon.h"

namespace mesocap::acquisition {

inline const std::string kServedToken = "0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef";

class ServedDaemonTest : public SimulatedDaemonTest {
 protected:
  ControlServerOptions Options() const {
    ControlServerOptions o;
    o.socket = state_ / "control.sock";
    o.tcp_port = 0;
    o.bearer_token = kServedToken;
    return o;
  }
};

}  // namespace mesocap::acquisition
