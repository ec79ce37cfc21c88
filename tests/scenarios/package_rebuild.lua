-- Rebuild a controller package and restart one leaf while the system runs (ARCHITECTURE.md, "Controller
-- packages"): a package built against this build tree's SDK (<build>/sdk) into the `packages/` folder beside the
-- system file, its leaf Scaled multiplying by a constant; the constant is changed in the C++ source, the package
-- rebuilt with cmake, and restart('sc') starts that leaf from the library as it is now on disk: the reader sees
-- the new factor, and no other process stopped (their pids are the same).
local S = require "dca.scenario"
local T = require "dca.testing"
S.backends = { "real" }

local build = os.getenv("DCA_BUILD_DIR") or error("DCA_BUILD_DIR is not set")
local root = T.tmpdir()

local function source(factor)
  T.write(root .. "/src/scaled.cpp", [[
// Scaled(host): Out = FACTOR * In.
#include <dca/controller.h>
#include <dca/registry.h>
namespace rebuilt {
constexpr double kFactor = ]] .. factor .. [[;
const dca::InSpec<double> kIn{.name = "In", .trigger = true};
const dca::OutSpec<double> kOut{.name = "Out"};
class Scaled final : public dca::PeriodicController {
  DCA_CONTROLLER(Scaled)
  void MainCalc() override {
    double x = 0;
    if (in_.read(x) == dca::Read::New) out_.write(kFactor * x);
  }
  dca::In<double> in_;
  dca::Out<double> out_;
};
dca::Manifest Scaled::Describe() {
  return {.type = "Scaled", .doc = "Out = a constant * In", .inputs = {kIn}, .outputs = {kOut},
          .params = {PeriodParam(0, "0: on each sample", Period::ZeroIsEventDriven)}};
}
Scaled::Scaled(const dca::ControllerContext& ctx)
    : PeriodicController(ctx, Period::ZeroIsEventDriven), in_(port(kIn)), out_(port(kOut)) {}
DCA_REGISTER_CONTROLLER(Scaled);
}  // namespace rebuilt
]])
end

local function sh(cmd)
  local out, rc = T.sh(cmd)
  if rc ~= 0 then error(cmd .. " failed (" .. tostring(rc) .. "):\n" .. out, 0) end
end

local sys

-- `cmd` run while the supervisors' loop goes on: a call that blocks it would silence the root supervisor for
-- longer than the fence, and the daemons would stop its leaves (docs/supervision.md, "Fencing").
local function sh_live(cmd)
  local log, status = root .. "/sh.log", root .. "/sh.status"
  os.remove(status)
  T.background("{ (" .. cmd .. "); echo $? > " .. status .. "; }", log)
  local function rc()
    local f = io.open(status)
    local text = f and f:read("a") or ""
    if f then f:close() end
    return tonumber(text:match("%d+"))
  end
  sys:wait(cmd, function() return rc() ~= nil end, 300)
  if rc() ~= 0 then error(cmd .. " failed (" .. rc() .. "):\n" .. T.read(log), 0) end
end

local PROCESSES = { "main.src", "main.sc", "main.sink", "main.other" }
local function pids()
  local t = {}
  for _, p in ipairs(PROCESSES) do t[p] = sys:pid(p) end
  return t
end

S.step("the package is built with factor 2 into packages/ beside the system", function()
  sh("mkdir -p " .. root .. "/src")
  T.write(root .. "/src/CMakeLists.txt", [[
cmake_minimum_required(VERSION 3.25)
project(rebuilt LANGUAGES CXX)
find_package(dca REQUIRED)
dca_add_controller_package(rebuilt SOURCES scaled.cpp OUTPUT_DIRECTORY ${SYSTEM_DIR}/packages)
]])
  source(2)
  sh("cmake -S " .. root .. "/src -B " .. root .. "/build -G Ninja -DCMAKE_BUILD_TYPE=Release -Ddca_DIR=" .. build ..
     "/sdk -DSYSTEM_DIR=" .. root .. " && cmake --build " .. root .. "/build")
  T.write(root .. "/rebuild.dca", [[
use rebuilt;
process main() {
  instantiated_processes {
    src   instof Counter("h1", 0.02);
    sc    instof Scaled("h1");
    sink  instof Threshold("h2", 1000000);
    other instof Threshold("h1", 1000000);
  }
  internal_connections(src, run) {
    src, Count -> sc, In;
    src, Count -> other, In;
  }
  internal_connections(sc, run) {
    sc, Out -> sink, In;
  }
  internal_event_actions { src[run], sc[run], sink, other }
}
]])
  sys = S.system(root .. "/rebuild.dca")
  sys:up()
  sys:run()
  -- twice the count: always even
  sys:wait_read("main.sink", "In", function(v) return type(v) == "number" and v > 0 and v % 2 == 0 end, 20)
end)

S.step("rebuilt with factor 3, restart('sc'): the new factor, the others never stopped", function()
  local before = pids()
  source(3)
  sh_live("cmake --build " .. root .. "/build")
  local repl = require("dca.supervisor.console").new(sys.sup)
  local out
  repl:eval("restart('sc')", function(o) out = o end)
  sys:wait("the console's answer", function() return out ~= nil end, 30)
  S.eq(out, "main.sc: restarted")
  S.ok(sys:pid("main.sc") ~= before["main.sc"], "a new process for main.sc")
  -- the reader now sees three times the count (a multiple of 3 that is no multiple of 2 proves the new code)
  sys:wait_read("main.sink", "In", function(v) return type(v) == "number" and v % 3 == 0 and v % 2 == 1 end, 20)
  for _, p in ipairs(PROCESSES) do
    if p ~= "main.sc" then S.eq(sys:pid(p), before[p], p .. " never stopped") end
  end
end)

local code = S.finish()
T.cleanup()
return code
