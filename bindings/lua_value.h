#pragma once
// Lua values <-> wire values (msgpack), for every binding that moves messages between Lua and the core.
//
// Lua -> wire: nil, booleans, integers, floats and strings (bytes) map to themselves. A table whose keys are
// exactly 1..n (n >= 1) is an array; any other table is a map (an empty table is an empty map). A sequence with
// nil holes ({1, nil, 3}) is therefore sent as a map with integer keys and comes back with the same keys and
// the same holes. Functions, userdata, threads, tables nested deeper than wire::kMaxDepth (or cyclic) are
// refused with an error naming the path ("msg.argv[2]: cannot send a function").
// wire -> Lua: maps become tables with the same keys (keys that cannot index a Lua table, such as NaN, are
// dropped), arrays become sequences (a nil element leaves a hole), msgpack bin and str both become strings.
//
// A message {type, id, payload} is the Lua table {type = "...", id = N, <payload fields>}: the top-level fields
// `type` and `id` are reserved (id is absent for events, whose id is 0).
#include <string>

#include "host/codec/wire.h"

struct lua_State;

namespace dca::lua {

/// Converts the Lua value at `index`. Never raises a Lua error: false with *error when it cannot.
bool to_value(lua_State* L, int index, wire::Value& out, std::string* error);
/// Pushes `v` (may raise a Lua memory error: call from a C function that Lua called, or under lua_pcall).
void push_value(lua_State* L, const wire::Value& v);
/// Converts the Lua table at `index` ({type = "...", [id = N,] ...}) to a message (id 0 without `id`).
/// Never raises.
bool to_message(lua_State* L, int index, wire::Message& out, std::string* error);
/// Removes the envelope's fields (`type`, `id`) from the map `payload`: they are not payload.
void drop_envelope_fields(wire::Value& payload);
/// Pushes message `m` as a table {type = m.type, id = m.id (when with_id and m.id != 0), <payload fields>}.
void push_message(lua_State* L, const wire::Message& m, bool with_id = true);

}  // namespace dca::lua
