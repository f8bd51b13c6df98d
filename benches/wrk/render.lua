-- GET a 512x512 PNG of the Cornell box whose light changes with every request.
local n = 0
request = function()
  n = n + 1
  return wrk.format("GET", string.format("/api/scenes/cornell-box/render.png?camera=front&w=512&h=512&light.ceiling=%.3f", 0.2 + (n % 100) / 50))
end
