-- `dca completion bash`: the bash completion script, generated from the commands' usage texts (dca.cli.doc).
local M = {}

M.summary = "print the bash completion script of dca's commands and options"
M.usage = [[usage: dca completion bash

Prints a bash completion script for dca: the commands after `dca`, a command's options after `-`, file names
otherwise. It is generated from the commands' own usage texts, so it knows what this dca knows. Use it with
  source <(dca completion bash)
or save it as ~/.local/share/bash-completion/completions/dca (the Debian package installs it for everyone).]]

function M.main(args)
  if args[1] ~= "bash" or args[2] then
    io.stderr:write("dca completion: ", args[1] and ("no completion for '" .. tostring(args[1]) .. "' (only bash)")
      or "which shell? (bash)", "\n", "usage: dca completion bash\n")
    return 2
  end
  local doc = require "dca.cli.doc"
  io.stdout:write(doc.bash(doc.commands(require("dca.core").exe_path())))
  return 0
end

return M
