"""amr_navigation: explore, localize, plan, follow. The one place that decides who drives (Navigator), the
library loop that carries its decisions out in process (NavigationLoop, run_navigation), and the navigator
lifecycle node that carries them out with the controller and planner nodes."""
