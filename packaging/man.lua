-- Writes the manual page dca(1) from its template (its COMMANDS section from the commands' usage texts) and the
-- bash completion script: dca lua packaging/man.lua TEMPLATE MAN_OUT COMPLETION_OUT   (packaging/CMakeLists.txt)
local template, man, completion = ...
assert(template and man and completion, "usage: dca lua man.lua TEMPLATE MAN_OUT COMPLETION_OUT")
local doc = require "dca.cli.doc"
local cmds = doc.commands(require("dca.core").exe_path())
local function write(path, text)
  local f = assert(io.open(path, "w"))
  f:write(text)
  f:close()
end
local f = assert(io.open(template, "r"))
write(man, doc.man(cmds, f:read("a")))
f:close()
write(completion, doc.bash(cmds))
