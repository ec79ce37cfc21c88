-- `dca upgrade PACKAGE --system PATH|ADDR`: a rolling upgrade of a controller package on a running system
-- (docs/deploy.md, "Rolling upgrade of a package"). The file's bytes go to the system's supervisor over its
-- console channel (authenticated with the cluster key, as `dca repl`); the supervisor rolls them out
-- (dca.supervisor.upgrade) and its lines are printed as they come.
local core = require "dca.core"
local args_mod, repl = require "dca.cli.args", require "dca.cli.repl"
local console = require "dca.clients.console"

local M = {}

M.summary = "roll a new build of a controller package to a running system's hosts, a canary first"
M.usage = [[usage: dca upgrade PACKAGE --system PATH|ADDR [--canary HOST] [--watch SECONDS] [--package NAME]
                   [--daemon ADDR] [--key FILE]

Rolls a new build of a controller package to the hosts of a running system that run leaves of it
(docs/deploy.md, "Rolling upgrade of a package"). PACKAGE is the file NAME.dca.so, or a folder that holds it
(a package's build folder; --package NAME picks one among several).
  --system PATH|ADDR  the supervisor that runs the upgrade (the root, e.g. main), found as `dca repl` finds
                      it: its path looked up at --daemon (or $DCA_DAEMON), or its control address
  --canary HOST       the host that goes first (default: the first by name of those running the package)
  --watch SECONDS     how long the canary runs before the other hosts get the new version (default 5;
                      5 or 5s)
  --key FILE          the cluster key (default $DCA_KEY_FILE, else the user's)
Each host's daemon installs the file (keeping the version it replaces); its leaves of the package restart live
onto it one by one while the rest of the system runs. A leaf of the canary that crashes, or a group above one
that escalates, within the watch rolls the canary back and stops: no other host receives the new version.
Prints the plan and each step; exit code 0 when every host runs the new version, 1 when rolled back or
stopped.]]

-- The package file PACKAGE names (a file, or the one NAME.dca.so of a folder). --> path | nil, err
local function package_file(path, name)
  local entries = core.list_dir(path)
  if not entries then
    if name and not path:match(name .. "%.dca%.so$") then
      return nil, path .. " is not " .. name .. ".dca.so"
    end
    return path
  end
  local found = {}
  for _, e in ipairs(entries) do
    local n = e:match("^([%w_]+)%.dca%.so$")
    if n and (not name or n == name) then found[#found + 1] = e end
  end
  table.sort(found)
  if #found == 1 then return path .. "/" .. found[1] end
  if #found == 0 then
    return nil, path .. " holds no " .. (name and name .. ".dca.so" or "package file (NAME.dca.so)")
  end
  return nil, path .. " holds " .. table.concat(found, ", ") .. ": pick one with --package NAME"
end

function M.main(argv)
  local o, err = args_mod.parse(argv, "dca upgrade", {
    ["--system"] = "value", ["--canary"] = "value", ["--watch"] = "value", ["--package"] = "value",
    ["--daemon"] = "value", ["--key"] = "value" })
  if not o then io.stderr:write(err, "\n", M.usage, "\n") return 2 end
  if not o[1] or not o.system then io.stderr:write(M.usage, "\n") return 2 end
  if o.watch then o.watch = tonumber(tostring(o.watch):match("^(.-)s?$")) or -1 end  -- 5 or 5s
  if o.watch and (o.watch < 0 or o.watch > 3600) then
    io.stderr:write("dca upgrade: --watch is seconds from 0 to 3600\n") return 2
  end
  local file, ferr = package_file(o[1], o.package)
  if not file then io.stderr:write("dca upgrade: ", ferr, "\n") return 2 end
  local name = file:match("([%w_]+)%.dca%.so$")
  local f, oerr = io.open(file, "rb")
  if not name or not f then
    io.stderr:write("dca upgrade: ", file, ": ", oerr or "a package file is named NAME.dca.so", "\n") return 2
  end
  local data = f:read("a")
  f:close()
  local key, loop = o.key or os.getenv("DCA_KEY_FILE"), core.loop()
  local addr, aerr, code = repl.find(loop, o.system, o.daemon or os.getenv("DCA_DAEMON"), key)
  if not addr then io.stderr:write("dca upgrade: ", aerr, "\n") return code end
  local c, cerr = repl.await(loop, 10, function(k) console.connect(addr, { key_file = key }, k) end)
  if not c then io.stderr:write("dca upgrade: ", addr, ": ", tostring(cerr), "\n") return 1 end
  -- the supervisor's lines of this upgrade, as they come; the answer repeats them (printed once each)
  local printed, prefix = {}, "upgrade " .. name .. ": "
  local function print_line(line)
    if line:sub(1, #prefix) ~= prefix or printed[line] then return end
    printed[line] = true
    io.stdout:write(line, "\n")
    io.stdout:flush()
  end
  repl.await(loop, 10, function(k) c:follow(print_line, k) end)
  local watch = o.watch or 5
  local r, uerr = repl.await(loop, watch + 600, function(k)
    c:request({ type = "upgrade", name = name, data = data, canary = o.canary, watch = o.watch }, watch + 590, k)
  end)
  c:close()
  local text = r and (r.type == "error" and r.reason or r.text) or uerr
  for line in tostring(text):gmatch("[^\n]+") do
    if line:sub(1, #prefix) == prefix then print_line(line)
    elseif not printed[line] then io.stdout:write(line, "\n") end
  end
  return (r and r.type ~= "error") and 0 or 1
end

return M
