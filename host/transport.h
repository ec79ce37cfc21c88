#pragma once
// How a connection travels (pure: no I/O): the one TCP/Unix enum, shared by the ports' connections (host/port.h)
// and the sockets' addresses (host/net/framed_socket.h). Part of the controller SDK, through host/port.h.
#include <cstdint>
#include <string_view>

namespace dca {

/// How a connection travels: inside the process, over a Unix stream socket, or over TCP. A socket's Address is
/// Unix or Tcp.
enum class Transport : std::uint8_t { InProcess, Unix, Tcp };
/// "inprocess", "unix" or "tcp".
std::string_view to_string(Transport t);

}  // namespace dca
