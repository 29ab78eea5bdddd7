"""Route networks, planning, missions and topological navigation (issue 14; seed 003 §3.4, §3.5, §3.9).

* :mod:`agvnav.routes.schema`, :mod:`agvnav.routes.network`: the route network file
  (nodes, directed edges with line/arc/clothoid/NURBS geometry, speed limits,
  allowed direction and models), its networkx graph and the continuity report;
* :mod:`agvnav.routes.planning`: shortest-time routes on (node, heading, direction) states;
* :mod:`agvnav.routes.mission`: jobs, legs and the speed limit profile along a leg;
* :mod:`agvnav.routes.topology`: where on the graph the vehicle is (topological navigation).
"""
