-- `dca upgrade PACKAGE --system main` as a person types it (docs/deploy.md, "Rolling upgrade of a package"):
-- against a `dca run` of three robots on three local daemons (tests/lua/launch/upgrade_robots.dca, the test
-- package pkg_ok beside it), reached as `dca repl` reaches the root (its path at a daemon, the cluster key).
-- The upgrade itself (crash, rollback, versions) is tests/lua/launch/upgrade_test.lua's.
local T = require "dca.testing"
local suite = T.suite("upgrade_cli")

local dca = T.exe
local packages = os.getenv("DCA_TEST_PACKAGES_DIR") or error("DCA_TEST_PACKAGES_DIR is not set")

suite:case("usage_and_a_package_that_cannot_be_named_exit_2", function()
  local out, rc = T.sh(dca .. " upgrade")
  T.eq(rc, 2)
  T.contains(out, "usage: dca upgrade PACKAGE --system PATH|ADDR")
  for _, w in ipairs({ "-1", "5m", "4000" }) do
    out, rc = T.sh(dca .. " upgrade " .. packages .. "/variants/k3 --system main --watch " .. w)
    T.eq(rc, 2, w)
    T.contains(out, "dca upgrade: --watch is seconds from 0 to 3600")
  end
  out, rc = T.sh(dca .. " upgrade " .. packages .. " --system main")
  T.eq(rc, 2)
  T.contains(out, "dca upgrade: " .. packages .. " holds ")
  T.contains(out, "pkg_ok.dca.so, pkg_old.dca.so")
  T.contains(out, ": pick one with --package NAME")
  out, rc = T.sh(dca .. " upgrade " .. packages .. "/variants --system main")
  T.eq(rc, 2)
  T.contains(out, "dca upgrade: " .. packages .. "/variants holds no package file (NAME.dca.so)")
end)

suite:case("rolls_a_package_folder_to_a_running_system_printing_the_plan_and_each_host", function()
  local dir = T.tmpdir()
  os.execute("mkdir '" .. dir .. "/packages' && cp '" .. packages .. "/pkg_ok.dca.so' '" .. dir .. "/packages/'")
  T.write(dir .. "/robots.dca", T.read(T.src .. "/tests/lua/launch/upgrade_robots.dca"))
  local log = dir .. "/run.log"
  local pid = T.background(dca .. " run " .. dir .. "/robots.dca", log)
  local text = T.wait_for(log, "whole tree is configured", 60)
  T.ok(text, "dca run came up")
  local daemon, key = text:match("console: dca repl main %-%-daemon (%S+) %-%-key (%S+)")
  T.ok(daemon and key, text)
  local cmd = string.format("%s upgrade %%s --system main --daemon %s --key %s", dca, daemon, key)

  -- a canary that runs none of it: refused before anything changes
  local out, rc = T.sh(string.format(cmd, packages .. "/variants/k3") .. " --canary h9")
  T.eq(rc, 1, out)
  T.contains(out, "upgrade pkg_ok: the canary h9 runs no leaf of it (hosts that do: h1, h2, h3)")

  out, rc = T.sh(string.format(cmd, packages .. "/variants/k3") .. " --canary h3 --watch 0.2s")
  T.eq(rc, 0, out)
  local lines = {}
  for l in out:gmatch("[^\n]+") do lines[#lines + 1] = l end
  T.ok(lines[1]:find("^upgrade pkg_ok: plan: %d+ bytes %(version %x+%) to 3 hosts, leaf by leaf: h3 %[canary%] "
    .. "%(main%.r3%.sc, runs %x+%), then h1 %(main%.r1%.sc, runs %x+%), then h2 %(main%.r2%.sc, runs %x+%); "
    .. "the canary watched 0%.2 s$"), out)
  T.ok(lines[2]:find("^upgrade pkg_ok: h3: installed version %x+ %(was %x+%)$"), out)
  T.eq(lines[3], "upgrade pkg_ok: h3: main.r3.sc restarted (1/1)")
  T.ok(lines[#lines]:find("^upgrade pkg_ok: done: 3 hosts run version %x+ %(h3, h1, h2%)$"), out)
  T.eq(#lines, 10, "each line once:\n" .. out)
  -- the run's own output says it too
  T.ok(T.wait_for(log, "upgrade pkg_ok: done: 3 hosts run version", 30), T.read(log))

  os.execute("kill -TERM " .. pid)
  T.ok(T.wait_exit(pid, 60), "dca run ended")
end)

return suite:run(...)
