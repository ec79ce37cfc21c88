-- dca.supervisor.child: one supervised child of a group (a leaf node or a child supervisor), its record
-- declared once, the states it may be in and the transitions between them. Pure: no I/O.
--
--   child.new(c)              --> the record of spec child `c` (state "new")
--   child.set(ch, to)         -- its state becomes `to`; a transition the table below does not allow raises an
--                             --   error naming the child's path, the state it was in and `to`
--   child.mark(ch, fields)    -- fields of its restart record set (ch.restart created when needed)
--   child.unmark(ch, ...)     -- those fields of its restart record cleared (the record dropped once empty)
--   child.restart(ch, field)  --> that field of its restart record, or nil
--   child.start_error(ch, err, how) --> why its process did not come up, as a line naming its path
--
-- The state of a child changes only through child.set (tests/layout/check.lua holds the tree to it).
local M = {}

local error, ipairs, next, pairs, select, type = error, ipairs, next, pairs, select, type
local sformat, tostring = string.format, tostring

--- The record of a child (fields beside these: none).
---   spec         the spec child (dca.supervisor.spec): kind, type, host, args; a moved child's is a copy
---   name, path   its name in the group, its path in the tree
---   kind         "leaf" | "group"
---   host         the host it runs on now (a failover moves it)
---   state        one of M.STATES, changed by M.set only
---   handle       the runtime's handle of its process (rt.spawn), nil while it has none
---   manual       true when a person runs it by hand (the algebra's is_running)
---   init         the init value of its last run (a restart runs it again with it)
---   run_no       the number of its runs (an answer to an older run is not a fault of this one)
---   exit_reason  why its process ended (exited, lost, a failed restart)
---   restarts     how often it was restarted (tree())
---   taps         the taps made on its leaves, made again after a restart (dca.supervisor.taps)
---   failover_hosts  the hosts it may move to after its host was lost (dca.supervisor.failover)
---   restart      nil, or the restart under way (any of these set; the record is dropped when none is):
---     replacing  its old process is being replaced: that process's events and exit are not faults
---     policy     the group's supervision policy restarts it (not a person): a failed restart escalates
---     fault      a fault of it waits for the policy (the restart is not under way yet)
---     pending    the algebra asked for its run meanwhile: it runs once restarted
---     note       the text of the budget used (" 1/3 in 10 s"), for its `restarted` line
function M.new(c)
  return { spec = c, name = c.name, path = c.path, kind = c.kind, host = c.host, state = "new", handle = nil,
           manual = false }
end

--- Why the process of child `ch` did not come up, from the runtime's spawn error `err`: a process that ended
--- while it started gave its own reason (`how` = "exited", dca.supervisor.net), which names its host; any
--- other error did not start it there.
function M.start_error(ch, err, how)
  if how == "exited" then return sformat("%s: %s", tostring(ch.path), tostring(err)) end
  return sformat("%s: could not start on host %s: %s", tostring(ch.path), tostring(ch.host), tostring(err))
end

--- The states, each with its meaning.
M.STATES = {
  new = "declared, no process yet",
  starting = "its process is being spawned",
  configuring = "a child supervisor configures its subtree",
  failed = "its start failed (or its restart: a supervisor not configured)",
  inactive = "its process is up, wired, not running",
  running = "started by the algebra (Run sent)",
  stopping = "aborted by the algebra, its stop not acknowledged yet",
  done = "it ended DONE",
  aborted = "it ended ABORTED",
  exited = "its process ended (a leaf), or its restart failed",
  lost = "its supervisor, channel or host was lost (a group)",
  restarting = "its process is being replaced (a restart)",
  gone = "stopped for good by the group's shutdown",
}

-- Every state the process of a child may end from (its exit, a shutdown).
local LIVE = { "new", "starting", "configuring", "failed", "inactive", "running", "stopping", "done", "aborted",
               "restarting" }

local function set_of(...)
  local s = {}
  for i = 1, select("#", ...) do
    local v = select(i, ...)
    if type(v) == "table" then for _, x in ipairs(v) do s[x] = true end else s[v] = true end
  end
  return s
end

--- The transitions: to = the states it may be entered from. A late answer (a spawn or a configure answered
--- after the child ended, or after the shutdown) still sets the state it reports.
M.FROM = {
  starting = set_of("new"),
  configuring = set_of("starting", "exited", "lost"),
  failed = set_of("starting", "configuring", "exited", "lost", "gone"),
  -- up (a start, a restart's new process, an acknowledged stop; running: the algebra ran the old process while
  -- it was being replaced)
  inactive = set_of("starting", "configuring", "stopping", "restarting", "inactive", "running", "exited", "lost",
                    "gone"),
  -- Run sent: after its start, its end, its stop, or an answer that failed (the algebra ended its run)
  running = set_of("inactive", "running", "done", "aborted", "stopping", "restarting"),
  stopping = set_of("inactive", "running", "done", "aborted", "stopping", "restarting", "lost", "failed"),
  -- its events (also when they cross its exit, or come from a new process before its run)
  done = set_of("running", "inactive", "aborted", "restarting", "exited", "lost"),
  aborted = set_of("running", "inactive", "aborted", "restarting", "exited", "lost"),
  exited = set_of(LIVE, "exited", "lost", "gone"),
  lost = set_of(LIVE),
  -- a restart: by hand from an up state; by the policy also a faulted child, or one the shutdown overtook
  restarting = set_of(LIVE, "exited", "lost", "gone"),
  gone = set_of(LIVE, "exited", "lost", "gone"),
}

function M.set(ch, to)
  local from = ch.state
  local ok = M.FROM[to]
  if not ok then error(sformat("%s: no state '%s'", tostring(ch.path), tostring(to)), 2) end
  if not ok[from] then
    error(sformat("%s: no transition from %s to %s", tostring(ch.path), tostring(from), tostring(to)), 2)
  end
  ch.state = to
end

function M.mark(ch, fields)
  local r = ch.restart or {}
  for k, v in pairs(fields) do r[k] = v end
  ch.restart = r
end

function M.unmark(ch, ...)
  local r = ch.restart
  if not r then return end
  for i = 1, select("#", ...) do r[select(i, ...)] = nil end
  if next(r) == nil then ch.restart = nil end
end

function M.restart(ch, field)
  return ch.restart and ch.restart[field]
end

return M
