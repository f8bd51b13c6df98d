-- POST a lighting state that changes every request; ask for binary f32.
wrk.method = "POST"
wrk.headers["Content-Type"] = "application/json"
wrk.headers["Accept"] = "application/octet-stream"
local n = 0
request = function()
  n = n + 1
  local body = string.format('{"lights": {"%s": %.3f}}', os.getenv("GROUP") or "ceiling", (n % 200) / 100)
  return wrk.format(nil, os.getenv("PATH_") , nil, body)
end
