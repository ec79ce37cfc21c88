-- Live changes to controller code (README "Change it while it runs", docs/packages.md "Rebuild and restart"): a
-- system using the test package pkg_ok from the `packages/` folder beside it runs under `dca scenario --backend
-- real`; a rebuilt pkg_ok (tests/packages/CMakeLists.txt, lib/variants/) is copied over its file in place, as `cp`
-- does, while the nodes run it; then restart('sc') from the root's console:
--   - one process per leaf: the leaf starts anew with the new code (k = 3 instead of 2);
--   - a shared node (--placement group): the node cannot replace a package it loaded, so the leaf moves to a
--     process of its own, which loads the new code, and stays there at later restarts (before, the restart was
--     refused); with the file unchanged the restart goes on and says it reuses the code that process loaded.
--   - a build whose output no longer has the name the system connects: the restart is refused naming the port
--     and the connection, before anything is wired to the new process (before, the system ran half-wired).
-- Every wait is on an event (a sample read, a console answer) with a deadline that only bounds a hang.
local T = require "dca.testing"
local suite = T.suite("live")

local dca = T.exe
local packages = os.getenv("DCA_TEST_PACKAGES_DIR") or error("DCA_TEST_PACKAGES_DIR is not set")

-- The system: Counter -> PkgScale (k = 2 in pkg_ok as built) -> Threshold, every leaf on h1.
local SYSTEM = [[
use pkg_ok;
process main() {
  instantiated_processes {
    src  instof Counter("h1", 0.02);
    sc   instof PkgScale("h1");
    sink instof Threshold("h1", 1000000);
  }
  internal_connections(src, run) { src, Count -> sc, In; }
  internal_connections(sc, run) { sc, Out -> sink, In; }
  internal_event_actions { src[run], sc[run], sink }
}
]]

-- The scenario's common part: the system up and running, k = 2 seen at the sink; say(line) types a line in the
-- root's console and returns its answer; replace(variant) copies a rebuilt pkg_ok over the file in place.
local PRELUDE = [[
local S = require "dca.scenario"
S.backends = { "real" }
local DIR, VARIANTS = %q, %q
local sys = S.system(DIR .. "/live.dca")
local function say(line) return sys:repl(line) end
local function replace(variant)
  local f = assert(io.popen("cp " .. VARIANTS .. "/" .. variant .. "/pkg_ok.dca.so " .. DIR .. "/packages/pkg_ok.dca.so 2>&1"))
  local out = f:read("a")
  S.ok(f:close(), "cp: " .. out)
end
-- a sample at the sink that only k = `k` writes: a multiple of k, not of the other factor (2 or 3), above `above`
local function wait_factor(k, above)
  local other = k == 2 and 3 or 2
  local v
  sys:wait_read("main.sink", "In", function(x)
    if type(x) == "number" and x > (above or 0) and x %% k == 0 and x %% other ~= 0 then v = x return true end
  end, 20)
  return v
end
S.step("the system runs pkg_ok as built: k = 2", function()
  sys:up()
  sys:run()
  wait_factor(2)
end)
]]

-- Runs the scenario `steps` (after the prelude) with `dca scenario --backend real --placement P`. --> output, rc
local function scenario(placement, steps)
  local dir = T.tmpdir()
  os.execute("mkdir '" .. dir .. "/packages' && cp '" .. packages .. "/pkg_ok.dca.so' '" .. dir .. "/packages/'")
  T.write(dir .. "/live.dca", SYSTEM)
  local file = T.write(dir .. "/live.lua", string.format(PRELUDE, dir, packages .. "/variants") .. steps
    .. "\nreturn S.finish()\n")
  local out, rc = T.sh("timeout 200 " .. dca .. " scenario --backend real --placement " .. placement .. " " .. file)
  T.kept_logs(out)
  return out, rc
end

suite:case("a_leaf_of_its_own_process_restarts_with_the_package_as_it_is_on_disk_now", function()
  local out, rc = scenario("process", [[
S.step("pkg_ok replaced in place by a build with k = 3, restart('sc'): k = 3", function()
  local before = sys:pid("main.sc")
  replace("k3")
  S.eq(say("restart('sc')"), "main.sc: restarted")
  S.ok(sys:pid("main.sc") ~= before, "a new process")
  wait_factor(3)
end)
]])
  T.eq(rc, 0, "the scenario passes\n" .. out)
end)

suite:case("a_restart_whose_new_code_renamed_a_connected_port_is_refused_naming_it_and_never_wired", function()
  local out, rc = scenario("process", [[
S.step("pkg_ok replaced in place by a build whose output Out is named Scaled: restart('sc') is refused", function()
  replace("renamed")
  S.contains(say("restart('sc')"), "restart of main.sc refused: its new code has no output 'Out' (outputs are: "
    .. "Scaled), which connection main.sc.Out -> main.sink.In (set main:sc[run]) uses")
  -- its old process was ended for the new one: the leaf ends ABORTED with the reason, its group decides
  local out = sys:wait_outcome(30)
  S.eq(out.type, "aborted")
  S.eq(out.path, "main.sc")
  S.contains(out.reason, "restart of main.sc refused: its new code has no output 'Out'")
  S.eq(#sys:lines_matching("^main%.sc: restarted"), 0, "never restarted, never wired")
  S.eq(#sys:lines_matching("^main%.sc: restart failed: restart of main%.sc refused: "), 1, "said in the output")
end)
]])
  T.eq(rc, 0, "the scenario passes\n" .. out)
end)

suite:case("a_leaf_of_a_shared_node_whose_package_changed_restarts_in_a_process_of_its_own", function()
  local out, rc = scenario("group", [[
S.step("the package unchanged: restart('sc') goes on, in the same node, with the code it loaded", function()
  local before = sys:pid("main.sc")
  local said = say("restart('sc')")
  S.contains(said, "main.sc: restarted (a fresh instance in shared node leaves:main@h1#" .. before
    .. " (--placement group), with the code that process loaded: package 'pkg_ok' is unchanged on disk)")
  S.eq(sys:pid("main.sc"), before, "the same process")
  wait_factor(2)
end)
S.step("pkg_ok replaced in place by a build with k = 3: restart('sc') moves it to a process of its own", function()
  local pid = sys:pid("main.sc")
  replace("k3")
  local said = say("restart('sc')")
  S.contains(said, "main.sc: restarted (moved out of shared node leaves:main@h1#" .. pid .. " (--placement "
    .. "group) (2 other leaves) to a process of its own: package 'pkg_ok' is not what that process loaded (")
  S.contains(said, "/packages/pkg_ok.dca.so changed on disk since this process loaded it) and cannot be replaced "
    .. "there; it runs the code as it is on disk now)")
  S.ok(sys:pid("main.sc") ~= pid, "a process of its own")
  S.eq(sys:pid("main.sink"), pid, "the others stay in the shared node")
  wait_factor(3)  -- the new code's samples flow to the leaves left in the shared node
end)
S.step("restarted again, it stays in a process of its own", function()
  local pid = sys:pid("main.sc")
  S.eq(say("restart('sc')"), "main.sc: restarted")
  S.ok(sys:pid("main.sc") ~= pid, "a fresh process")
  S.ok(sys:pid("main.sc") ~= sys:pid("main.sink"), "not the shared node")
  wait_factor(3)
end)
]])
  T.eq(rc, 0, "the scenario passes\n" .. out)
end)

return suite:run(...)
