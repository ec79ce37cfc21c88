-- A fleet (docs/supervision.md, "A fleet"), in memory and with real daemons on loopback (one per host: base, door,
-- r1, r2, r3): light robots added while the system runs, each a group whose supervisor and Counter run on its own
-- host; one crashed and restarted by the root's policy like its first children; one removed, its processes gone.
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/fleet.dca")

S.step("up and running: the door only, no robot yet", function()
  sys:up()
  sys:run()
  sys:wait_state("main.door", "running", 10)
  S.eq(sys:repl("fleet()"), "main.robots: Robot on { r1, r2, r3 }: no instance")
end)

S.step("two robots join: each runs on its own host", function()
  S.eq(sys:repl('add_child("robots", "r2")'), "main.robots_r2: added on host r2")
  S.eq(sys:repl('add_child("robots", "r3")'), "main.robots_r3: added on host r3")
  sys:wait_state("main.robots_r2.light", "running", 10)
  sys:wait_state("main.robots_r3.light", "running", 10)
  S.eq(sys:host("main.robots_r2.light"), "r2")
  S.ok(sys:exists("main.robots_r2.light"), "its node runs on r2's daemon")
  S.contains(sys:repl("fleet()"), "main.robots_r2 on r2 (running), main.robots_r3 on r3 (running)")
end)

S.step("a robot's supervisor killed: restarted by the root's policy, the other robot untouched", function()
  local from = #sys:transitions()
  sys:kill("main.robots_r2", "KILL")
  sys:wait_restart("main.robots_r2", 10, from)
  sys:wait_state("main.robots_r2.light", "running", 10)
  S.ok(#sys:lines_matching("^main%.robots_r2: restarted", from) == 1, "one restart of it")
  S.eq(sys:lines_matching("^main%.robots_r3", from), {}, "nothing happened to the other robot")
  S.contains(sys:repl("fleet()"), "main.robots_r2 on r2 (running), main.robots_r3 on r3 (running)")
end)

S.step("a robot leaves: its processes are gone, the rest runs on", function()
  S.eq(sys:repl('remove_child("robots_r2")'), "main.robots_r2: removed")
  S.eq(sys:exists("main.robots_r2.light"), false)
  S.eq(sys:exists("main.robots_r2"), false)
  S.ok(sys:exists("main.robots_r3.light"))
  S.contains(sys:repl('add_child("robots", "r9")'), "host r9 is not one of its hosts (r1, r2, r3)")
  S.eq(sys:repl("fleet()"), "main.robots: Robot on { r1, r2, r3 }: main.robots_r3 on r3 (running)")
end)

return S.finish()
