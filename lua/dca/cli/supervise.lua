-- `dca supervise --name PATH --daemon ADDR [--key FILE]`: one DCAS (a process-group instance), started by the
-- daemon of its group's host on behalf of the parent supervisor (dca.launch.group does the work). It exits
-- when its parent asks (shutdown) or goes away (everything it started is stopped first).
local core, args_mod = require "dca.core", require "dca.cli.args"

local USAGE = "dca supervise --name PATH --daemon ADDR [--key FILE] [--listen ADDR]"

local function parse(args)
  local o, err = args_mod.parse(args, "dca supervise",
    { ["--name"] = "value", ["--daemon"] = "value", ["--key"] = "value", ["--listen"] = "value" }, 0)
  if not o then return nil, err end
  if not o.name or not o.daemon then return nil, "--name and --daemon are required" end
  return o
end

local OUT = {
  error = function(text) io.stderr:write("dca supervise: ", text, "\n") end,
  line = function(text) io.stderr:write(text, "\n") end,
  verbose = os.getenv("DCA_SUPERVISE_VERBOSE") ~= nil,
}

local function main(args)
  if not core.loop or not core.connect then
    io.stderr:write("dca supervise: this dca has no control plane (dca.core.loop/connect)\n")
    return 3
  end
  local o, err = parse(args)
  if not o then io.stderr:write("dca supervise: ", (err:gsub("^dca supervise: ", "")), "\nusage: ", USAGE, "\n") return 2 end
  return require("dca.launch.group").main(o, OUT)
end

return { summary = "run one supervisor (DCAS) of a process group; started by a daemon", usage = USAGE, main = main }
