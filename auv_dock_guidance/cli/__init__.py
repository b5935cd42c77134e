"""The auv-dock command-line tool."""
